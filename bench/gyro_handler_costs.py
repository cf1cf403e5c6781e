"""What the node's own Python costs per gyro message, warm, layer by layer.

Builds the installed node in-process on the ``strapdown`` scene (no subscriber, so no output
is published: only the node's own work is timed) and feeds its raw ``imu`` handler, and then
each layer of it separately, 100 000 serialized Imu messages at 20 kHz stamps after a warm-up
of as many: the decoder, the gyro stream (time rules, the exp-map step), the output attitude's
sign continuity, the outputs' subscription counts, the pose encoder, and the whole handler
(call chain, state lock and session checks included). Also the same per-message work of
``bench/fast_relay.py`` (decode the rate, pack the pose, no integration). Wall time per
message (µs) and the ratio to the whole handler, one run.

Usage: ``python bench/gyro_handler_costs.py [--messages 100000]``; findings in ``NOTES.md``,
section 10.
"""

import argparse
import os
import struct
import sys
import time
from typing import Callable, Iterable, List, Optional, Tuple

from _common import header_cdr, imu_gyro

os.environ.setdefault('ROS_DOMAIN_ID', '95')
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

STAMP0_NS = 1_700_000_000 * 1_000_000_000
PERIOD_NS = 50_000  # 20 kHz
RATE = (0.1, 0.2, 0.3)


def per_message_us(function: Callable, items: Iterable, count: int) -> float:
    """Wall time per call of ``function`` over ``items`` (µs)."""
    start = time.perf_counter()
    for item in items:
        function(item)
    return 1e6 * (time.perf_counter() - start) / count


def measure(count: int) -> List[Tuple[str, float]]:
    """(layer, µs per message) of the node's gyro path and of the fast relay's work."""
    from rigid_body_attitude.ros.middleware import use_packaged_fastdds_profile
    use_packaged_fastdds_profile()
    import rclpy
    from rclpy.parameter import Parameter
    from rigid_body_attitude.ros.node import AttitudePropagatorNode
    from rigid_body_attitude.session.decoding import DECODERS

    rclpy.init()
    try:
        node = AttitudePropagatorNode(
            parameter_overrides=[Parameter('scene', value='strapdown')])
        session, outputs = node.session, node.outputs
        handler = node.handlers['imu']
        per_message_us(handler, imu_messages(0, count), count)  # warm-up
        rows = [('decode (session decoder)', per_message_us(DECODERS['imu'],
                                                            imu_messages(0, count), count))]
        stamps = [STAMP0_NS + (2 * count + k) * PERIOD_NS for k in range(count)]
        add = session.stream.add
        rows.append(('gyro stream: time rules and exp-map step',
                     per_message_us(lambda stamp: add(stamp, RATE), stamps, count)))
        attitude, propagator = session.tracker.attitude, session.propagator
        rows.append(('output attitude (sign continuity)',
                     per_message_us(lambda _: attitude(propagator), range(count), count)))
        rows.append(('outputs: three subscription counts, nothing published',
                     per_message_us(lambda _: outputs.attitude(1, 2, (1.0, 0.0, 0.0, 0.0), None),
                                    range(count), count)))
        encode = outputs.encode_pose
        rows.append(('pose encoder', per_message_us(
            lambda _: encode(1, 2, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0)), range(count),
            count)))
        rows.append(('whole raw handler', per_message_us(handler, imu_messages(3 * count, count),
                                                         count)))
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    rows.append(('fast relay: decode rate, pack pose', per_message_us(
        relay_work(), imu_messages(0, count), count)))
    return rows


def imu_messages(first: int, count: int) -> List[bytes]:
    """``count`` serialized Imu messages, the ``first``-th sample's stamp on."""
    from rigid_body_attitude.msgs.cdr import encode_imu
    return [encode_imu(STAMP0_NS + (first + k) * PERIOD_NS, 'imu_link', RATE)
            for k in range(count)]


def relay_work() -> Callable[[bytes], Optional[bytes]]:
    """``bench/fast_relay.py``'s per-message work: the gyro rate and the pose bytes."""
    frame = header_cdr('world')
    buffer = bytearray(frame + struct.pack('<7d', 0, 0, 0, 0, 0, 0, 1))
    offset, quaternion = len(frame) + 24, struct.Struct('<4d')

    def work(imu: bytes) -> Optional[bytes]:
        if imu_gyro(imu) is None:
            return None
        buffer[4:12] = imu[4:12]
        quaternion.pack_into(buffer, offset, 0.0, 0.0, 0.0, 1.0)
        return bytes(buffer)
    return work


def main(argv: Optional[List[str]] = None) -> int:
    """Measure and print a Markdown table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--messages', type=int, default=100_000)
    args = parser.parse_args(argv)
    rows = measure(args.messages)
    whole = dict(rows)['whole raw handler']
    print('| layer | µs per message | ÷ whole handler |')
    print('|---|---:|---:|')
    for label, cost in rows:
        print(f'| {label} | {cost:.2f} | {cost / whole:.2f} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
