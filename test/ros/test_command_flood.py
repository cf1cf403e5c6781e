"""Commands never flood the log nor stall the integrator, even with a console read slowly.

The installed node runs with its stdout and stderr on pipes that a reader empties one line
every 0.1 s (a launcher or supervisor that falls behind). A burst of 2 000 ``set_pose``
messages is followed by a 200 Hz gyro stream of 2 400 samples: every sample is integrated
(one ``pose`` per sample, its stamp checked) and the log holds only a few ``set_pose`` lines.
"""

from __future__ import annotations

import signal
import threading
import time

from geometry_msgs.msg import PoseStamped
from rclpy.qos import qos_profile_sensor_data
from ros_helpers import unique_namespace
from test_input_qos import (
    connect, missing_stamps, receive_all, RELIABLE_PUBLISHER_QOS, start_node)

#: Seconds the slow reader waits between two lines.
READ_PERIOD = 0.1


class SlowReader:
    """Reads a pipe one line per :data:`READ_PERIOD` until :meth:`stop`."""

    def __init__(self, stream) -> None:
        """Start reading ``stream`` in a thread."""
        self.stream, self.lines = stream, []
        self._hurry = threading.Event()
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self) -> None:
        for line in iter(self.stream.readline, ''):
            self.lines.append(line)
            if not self._hurry.is_set():
                time.sleep(READ_PERIOD)

    def finish(self) -> list[str]:
        """Read the rest without waiting (the process has ended); every line read."""
        self._hurry.set()
        self.thread.join(10.0)
        assert not self.thread.is_alive()
        return self.lines


def test_a_set_pose_burst_neither_floods_the_log_nor_stalls_the_gyro_path(
        ros, request, processes):
    """2 000 set_pose, then 2 400 gyro samples at 200 Hz: all integrated; at most a few
    set_pose log lines (throttled, with a count), the newest pose applied."""
    namespace = unique_namespace(request)
    node = start_node(processes, namespace)
    readers = [SlowReader(node.stderr), SlowReader(node.stdout)]
    harness, sender, poses = connect(ros, namespace, qos_profile_sensor_data)
    set_pose = harness.publisher(PoseStamped, 'set_pose', RELIABLE_PUBLISHER_QOS)
    harness.wait_for_connections()
    pose = PoseStamped()
    pose.header.frame_id = 'world'
    for k in range(2000):
        pose.pose.orientation.w = 1.0 + k  # normalised by the node
        set_pose.publish(pose)
    count = 2400
    pacer = threading.Thread(target=sender.paced, args=(200.0, count))
    pacer.start()
    try:
        receive_all(harness, poses, count, 20.0)
    finally:
        pacer.join()
    receive_all(harness, poses, count, 3.0)
    node.send_signal(signal.SIGINT)
    code = node.wait(15.0)
    log = ''.join(readers[0].finish() + readers[1].finish())
    assert code == 0, log
    assert missing_stamps(poses, count) == []
    pose_lines = [line for line in log.splitlines() if 'set_pose: attitude' in line]
    assert 1 <= len(pose_lines) <= 4, pose_lines
    assert 'Traceback' not in log
