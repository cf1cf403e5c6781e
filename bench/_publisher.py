"""Benchmark helper process: publish ``sensor_msgs/Imu`` on ``imu`` at a fixed rate.

Run by ``bench/node_throughput.py``; not meant for direct use. The message is serialized once;
per message only the header stamp is rewritten (to the wall clock, ``time.time_ns()``, at the
moment of publishing) and the bytes are handed to ``rcl_publish_serialized_message``, so one
message costs a few microseconds of Python. Pacing is against absolute due times
(``t0 + i / rate``): the loop sleeps only when it is ahead and otherwise publishes every
message that is due, so short stalls are caught up in a burst instead of lowering the rate.

``--mag-every N`` also publishes a ``sensor_msgs/MagneticField`` (``--mag`` [T], reliable) on
``imu/mag`` with every N-th Imu, stamped alike: the attitude filter's magnetometer.

``--gyro`` and ``--accel`` set the message's ``angular_velocity`` [rad/s] and
``linear_acceleration`` [m/s²]; all zero acceleration (the default) means "no accelerometer
data", so the node does not level. Gravity there (``--accel 0.3,-0.4,9.79``) with a rate under
the rest detector's 0.05 rad/s (``--gyro 0.01,-0.02,0.03``) is a body at rest: the node levels
during the warm-up, takes the window's mean rate as its gyro bias, then integrates.

Protocol (one JSON object per stdout line): ``{"event": "matched"}`` once a subscription is
matched, ``{"event": "start", ...}`` when the measured window begins, ``{"event": "end", ...}``
with the counts when it ends. The process then keeps its writer alive (so RELIABLE resends can
still reach a slow reader) until its stdin is closed.
"""

import argparse
import json
import sys
import time

from _common import IMU_TOPIC, imu_cdr, reliable_qos, set_stamp_ns
import rclpy
from sensor_msgs.msg import Imu, MagneticField

from rigid_body_attitude.msgs.cdr import encode_magnetic_field


#: The message's frame: the node's default ``body_frame``, so the rates are body rates and the
#: node waits for no mount on ``/tf_static`` (targets with ``mount_rpy`` take that instead).
BODY_FRAME = 'base_link'


def _emit(**fields) -> None:
    print(json.dumps(fields), flush=True)


def _vector(text: str) -> tuple:
    """Three comma-separated numbers."""
    values = tuple(float(value) for value in text.split(','))
    if len(values) != 3:
        raise argparse.ArgumentTypeError(f'expected X,Y,Z, got {text!r}')
    return values


def _paced_publish(publish_raw, message: bytearray, rate_hz: float, count: int,
                   field=None) -> dict:
    """Publish ``count`` copies of ``message`` at ``rate_hz``; return pacing statistics.
    ``field``: ``(publish_raw, message, every)`` of the magnetometer, or None."""
    period_ns = 1e9 / rate_hz
    monotonic_ns = time.monotonic_ns
    wall_ns = time.time_ns
    sleep = time.sleep
    start_ns = monotonic_ns()
    first_stamp = last_stamp = 0
    max_lag_ns = 0
    sent = 0
    while sent < count:
        due_ns = start_ns + int(sent * period_ns)
        now_ns = monotonic_ns()
        if now_ns < due_ns:
            sleep((due_ns - now_ns) * 1e-9)
            continue
        max_lag_ns = max(max_lag_ns, now_ns - due_ns)
        last_stamp = wall_ns()
        set_stamp_ns(message, last_stamp)
        if field is not None and sent % field[2] == 0:
            set_stamp_ns(field[1], last_stamp)
            field[0](bytes(field[1]))
        publish_raw(bytes(message))
        if sent == 0:
            first_stamp = last_stamp
        sent += 1
    elapsed_s = (monotonic_ns() - start_ns) * 1e-9
    return {'sent': sent, 'first_stamp_ns': first_stamp, 'last_stamp_ns': last_stamp,
            'elapsed_s': elapsed_s,
            'achieved_hz': (sent - 1) / ((last_stamp - first_stamp) * 1e-9) if sent > 1 else 0.0,
            'max_lag_ms': max_lag_ns * 1e-6}


def main() -> int:
    """Publish at ``--rate`` for ``--warmup`` then ``--duration`` seconds; report on stdout."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--rate', type=float, required=True, help='messages per second')
    parser.add_argument('--duration', type=float, default=4.0, help='measured seconds')
    parser.add_argument('--warmup', type=float, default=0.5, help='unmeasured seconds first')
    parser.add_argument('--gyro', type=_vector, default=(0.1, -0.2, 0.3),
                        help='angular_velocity WX,WY,WZ [rad/s] (default %(default)s)')
    parser.add_argument('--accel', type=_vector, default=(0.0, 0.0, 0.0),
                        help='linear_acceleration AX,AY,AZ [m/s^2] (default: zeros, i.e. no '
                             'accelerometer data)')
    parser.add_argument('--mag-every', type=int, default=0,
                        help='publish a MagneticField on imu/mag with every N-th Imu (0: none)')
    parser.add_argument('--mag', type=_vector, default=(0.0, 2.0e-5, -4.0e-5),
                        help='magnetic_field MX,MY,MZ [T] (default %(default)s)')
    parser.add_argument('--settle', type=float, default=0.5,
                        help='seconds to wait after the first match before publishing')
    parser.add_argument('--match-timeout', type=float, default=20.0)
    args, ros_args = parser.parse_known_args()

    rclpy.init(args=[sys.argv[0]] + ros_args)
    node = rclpy.create_node('bench_imu_publisher')
    publisher = node.create_publisher(Imu, IMU_TOPIC, reliable_qos())
    field_publisher = node.create_publisher(MagneticField, 'imu/mag', reliable_qos())
    try:
        deadline = time.monotonic() + args.match_timeout
        while publisher.get_subscription_count() < 1:
            if time.monotonic() > deadline:
                _emit(event='error', reason='no subscription matched')
                return 2
            time.sleep(0.01)
        _emit(event='matched')
        time.sleep(args.settle)
        message = imu_cdr(args.gyro, BODY_FRAME, args.accel)
        publish_raw = publisher.handle.publish_raw
        field = None
        if args.mag_every > 0:
            field = (field_publisher.handle.publish_raw, bytearray(encode_magnetic_field(
                0, BODY_FRAME, args.mag)), args.mag_every)
        _paced_publish(publish_raw, message, args.rate, max(1, int(args.warmup * args.rate)),
                       field)
        _emit(event='start', wall_ns=time.time_ns())
        stats = _paced_publish(publish_raw, message, args.rate, int(args.duration * args.rate),
                               field)
        _emit(event='end', wall_ns=time.time_ns(), **stats)
        sys.stdin.read()
    except KeyboardInterrupt:
        pass  # stopped by the driver
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
