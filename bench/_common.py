"""Shared pieces of the throughput benchmark: QoS, wire layouts and tiny process helpers.

Everything here is used by the helper processes (publisher, subscriber, relays) and by the
driver, ``bench/node_throughput.py``. The CDR helpers encode and decode the few fields the
benchmark needs straight from the serialized bytes, so the measuring processes never build
Python message objects on their hot path (building an ``Imu`` costs ~7 µs, deserializing one
~20 µs).

CDR (XCDR1, little endian) layouts used here, offsets counted from the start of the buffer,
which begins with the 4-byte encapsulation header ``00 01 00 00``:

* ``std_msgs/Header``: ``int32 sec`` at 4, ``uint32 nanosec`` at 8, ``uint32 len`` at 12
  (string length including its NUL), the ``frame_id`` bytes from 16.
* Body alignment: doubles are 8-aligned relative to offset 4 (the end of the header bytes).
* ``sensor_msgs/Imu`` body: orientation (4 doubles), orientation_covariance (9),
  angular_velocity (3), angular_velocity_covariance (9), linear_acceleration (3),
  linear_acceleration_covariance (9): 37 doubles, 296 bytes.
* ``geometry_msgs/PoseStamped`` body: position (3 doubles), orientation (4): 56 bytes.
"""

from __future__ import annotations

import os
import struct
from typing import Dict, Optional, Set, Tuple

#: Topic names every benchmark process uses (relative, so ``--ros-args -r`` remaps them).
IMU_TOPIC = 'imu'
POSE_TOPIC = 'pose'

#: History depth for the benchmark QoS (RELIABLE, KEEP_LAST): a deep queue, so nothing is lost
#: to the queue itself.
#: ``node_throughput.py --depth`` sets it for every helper process through this variable.
QUEUE_DEPTH = int(os.environ.get('BENCH_QUEUE_DEPTH', '10000'))

_STAMP = struct.Struct('<iI')
_BODY_OFFSET_IMU_GYRO = 13 * 8  # orientation (4) + orientation_covariance (9) doubles
_VEC3 = struct.Struct('<3d')
_CDR_LE_HEADER = b'\x00\x01\x00\x00'


def ros_env(domain_id: int) -> Dict[str, str]:
    """Return a copy of the environment for a benchmark process on ``domain_id`` (localhost)."""
    env = dict(os.environ)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    # BENCH_DISCOVERY_RANGE=SUBNET measures ROS's default range (then pick an unused domain).
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = os.environ.get('BENCH_DISCOVERY_RANGE', 'LOCALHOST')
    env['PYTHONUNBUFFERED'] = '1'
    env['PYTHONFAULTHANDLER'] = '1'  # a crash of a Python target leaves its traceback in the log
    return env


def reliable_qos(depth: int = QUEUE_DEPTH):
    """Return the benchmark QoS: RELIABLE, VOLATILE, KEEP_LAST ``depth``."""
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    return QoSProfile(depth=depth, history=HistoryPolicy.KEEP_LAST,
                      reliability=ReliabilityPolicy.RELIABLE)


def _body_start(frame_id_length: int) -> int:
    """Offset of the first 8-aligned body field after a header with this frame_id length."""
    end = 16 + frame_id_length  # 4 encapsulation + 8 stamp + 4 length + characters
    return 4 + ((end - 4 + 7) // 8) * 8


def header_cdr(frame_id: str) -> bytes:
    """Return the CDR bytes of a zero-stamp ``std_msgs/Header`` up to the aligned body start."""
    text = frame_id.encode() + b'\x00'
    head = _CDR_LE_HEADER + _STAMP.pack(0, 0) + struct.pack('<I', len(text)) + text
    return head + b'\x00' * (_body_start(len(text)) - len(head))


def imu_cdr(omega_body: Tuple[float, float, float], frame_id: str = 'imu',
            accel: Tuple[float, float, float] = (0.0, 0.0, 0.0)) -> bytearray:
    """Return a serialized ``sensor_msgs/Imu`` with zero stamp, the given angular velocity and
    linear acceleration (zeros: no accelerometer data).

    The orientation is the identity with covariance ``-1`` in element 0 (REP-145: "no
    orientation estimate"); all other fields are zero.
    """
    orientation = struct.pack('<4d', 0.0, 0.0, 0.0, 1.0)
    orientation_covariance = struct.pack('<9d', -1.0, *([0.0] * 8))
    body = (orientation + orientation_covariance + _VEC3.pack(*omega_body)
            + bytes(9 * 8) + _VEC3.pack(*accel) + bytes(9 * 8))
    return bytearray(header_cdr(frame_id) + body)


def set_stamp_ns(buffer: bytearray, stamp_ns: int) -> None:
    """Write ``stamp_ns`` (nanoseconds since the epoch) into a serialized header's stamp."""
    _STAMP.pack_into(buffer, 4, stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000)


def stamp_ns(buffer: bytes) -> int:
    """Return the header stamp (nanoseconds) of a serialized stamped message."""
    sec, nanosec = _STAMP.unpack_from(buffer, 4)
    return sec * 1_000_000_000 + nanosec


def imu_gyro(buffer: bytes) -> Optional[Tuple[float, float, float]]:
    """Return ``angular_velocity`` of a serialized little-endian Imu, or None if not CDR LE."""
    if buffer[1] != 1:
        return None
    (length,) = struct.unpack_from('<I', buffer, 12)
    return _VEC3.unpack_from(buffer, _body_start(length) + _BODY_OFFSET_IMU_GYRO)


def cpu_seconds(pid: int) -> float:
    """Return the run time (s) of every live thread of ``pid`` summed, from
    /proc/<pid>/task/*/schedstat: nanoseconds, where /proc/<pid>/stat has 10 ms ticks (a 4 s
    window's CPU in steps of 0.25 % of a core). A thread that ended is no longer counted."""
    return sum(run_ns for _, run_ns in thread_run_ns(pid).values()) * 1e-9


def thread_run_ns(pid: int) -> Dict[int, Tuple[str, int]]:
    """Return {tid: (thread name, run time in ns)} for every thread of ``pid``
    (/proc/<pid>/task/<tid>/comm and schedstat)."""
    return {tid: (name, run_ns) for tid, (name, run_ns, _) in thread_stats(pid).items()}


def thread_stats(pid: int) -> Dict[int, Tuple[str, int, int]]:
    """Return {tid: (thread name, run time in ns, voluntary context switches)} for every live
    thread of ``pid`` (/proc/<pid>/task/<tid>/comm, schedstat and status)."""
    found = {}
    for task in os.listdir(f'/proc/{pid}/task'):
        try:
            with open(f'/proc/{pid}/task/{task}/comm') as comm:
                name = comm.read().rstrip('\n')
            with open(f'/proc/{pid}/task/{task}/schedstat') as schedstat:
                run_ns = int(schedstat.read().split()[0])
            with open(f'/proc/{pid}/task/{task}/status') as status:
                switches = int(status.read().split('voluntary_ctxt_switches:')[1].split()[0])
        except (FileNotFoundError, ProcessLookupError, IndexError):
            continue  # the thread ended meanwhile
        found[int(task)] = (name, run_ns, switches)
    return found


def cpu_by_thread_name(before: Dict[int, Tuple[str, int]], after: Dict[int, Tuple[str, int]],
                       seconds: float) -> Dict[str, float]:
    """Return % of one core per thread name between two :func:`thread_run_ns` snapshots.

    Threads with the same name (several ``python`` threads) are summed; names with a Fast DDS
    port or index suffix (``dds.shm.7413``) are kept whole.
    """
    percent: Dict[str, float] = {}
    for tid, (name, run_ns) in after.items():
        delta = run_ns - before.get(tid, (name, 0))[1]
        if delta > 0:
            percent[name] = percent.get(name, 0.0) + 100.0 * delta * 1e-9 / seconds
    return dict(sorted(percent.items(), key=lambda item: -item[1]))


def process_ticks() -> Dict[int, int]:
    """Return {pid: utime + stime + cutime + cstime} of every process (/proc/<pid>/stat).

    A process's own times are its threads' scheduler run times (exact, not tick samples);
    cutime + cstime add the children it reaped."""
    ticks = {}
    for entry in os.listdir('/proc'):
        if not entry.isdigit():
            continue
        try:
            with open(f'/proc/{entry}/stat') as stat:
                fields = stat.read().rsplit(')', 1)[1].split()
        except (FileNotFoundError, ProcessLookupError):
            continue  # ended meanwhile
        ticks[int(entry)] = sum(int(field) for field in fields[11:15])  # fields 14-17
    return ticks


def other_load_ticks(before: Dict[int, int], after: Dict[int, int], ours: Set[int]) -> int:
    """Clock ticks used between two :func:`process_ticks` snapshots by processes not in
    ``ours`` (a process that started and ended in between is missed unless a survivor reaped
    it)."""
    return sum(ticks - before.get(pid, 0) for pid, ticks in after.items() if pid not in ours)


def rss_kib(pid: int) -> int:
    """Return the resident set size (KiB) of process ``pid`` from /proc/<pid>/status."""
    with open(f'/proc/{pid}/status') as status:
        for line in status:
            if line.startswith('VmRSS:'):
                return int(line.split()[1])
    raise RuntimeError(f'no VmRSS line for pid {pid}')
