"""The docs' plain rclpy controller (docs/closed-loop.md quotes bench/plain_controller.py) in
lockstep with the installed node: the quoted text is the file, and the file, run as a user runs
it (``python plain_controller.py``, rclpy's stock executor, its own process), closes the loop:
every tick answered, no lockstep timeout, and the attitudes at every tick those of the core's
propagator with the same law in the scene (``attitude_pd``, sampled at every tick and held over
it) to 1e-9 rad."""

from __future__ import annotations

import os
from pathlib import Path
import re
import subprocess
import sys

from controller_process import assert_every_tick_answered, stop_controller
from nav_msgs.msg import Odometry
import numpy as np
from ros_helpers import Harness, unique_namespace
from test_node_subprocess import read_until, SERVING, start, stop_with_sigint
import yaml

from rigid_body_attitude.core.attitude.quaternion import attitude_error
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.propagator import DynamicsPropagator

REPO_ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = REPO_ROOT / 'bench' / 'plain_controller.py'
TICK_NS = 10_000_000  # 100 Hz
TICKS = 300
KP, KD, LIMIT = 0.05, 0.04, 0.02
ATTITUDE = [0.8660254037844387, 0.28867513459481287, 0.28867513459481287,
            0.28867513459481287]


def scene(effect: dict) -> dict:
    return {'name': 'plain_loop', 'description': 'a slew under torque limits',
            'rate_source': 'dynamics', 'integrator': 'rk4', 'step': 0.001,
            'body': {'mass': 2.0, 'inertia': {'box': {'edges': [0.1, 0.2, 0.3],
                                                      'about': 'centre'}}},
            'initial_state': {'attitude': ATTITUDE, 'omega_body': [0.0, 0.01, 0.0]},
            'effects': [effect]}


def quoted_example() -> str:
    """The Python block of docs/closed-loop.md that follows the line naming the file."""
    text = (REPO_ROOT / 'docs' / 'closed-loop.md').read_text()
    match = re.search(r'`bench/plain_controller\.py`.*?:\n\n```python\n(.*?)```', text,
                      re.DOTALL)
    assert match, 'docs/closed-loop.md quotes no bench/plain_controller.py'
    return match.group(1)


def test_the_docs_quote_the_plain_controller_verbatim():
    assert quoted_example() == EXAMPLE.read_text()


def test_the_plain_controller_closes_the_lockstep_loop(ros, request, tmp_path):
    namespace = unique_namespace(request)
    scene_path = tmp_path / 'commanded.yaml'
    scene_path.write_text(yaml.safe_dump(scene({'commanded_torque': {'timeout': 0.5}})))
    harness = Harness(ros, namespace)
    odom = harness.record(Odometry, 'odom')
    node = start('--ros-args', '-r', f'__ns:={namespace}', '-p', f'scene:={scene_path}',
                 '-p', 'lockstep:=true', '-p', 'publish_rate:=100.0',
                 '-p', 'real_time_factor:=0.0', '-p', 'lockstep_timeout:=60.0')
    controller = None
    try:
        read_until(node, SERVING)
        harness.wait_for_connections()
        controller = subprocess.Popen(
            [sys.executable, str(EXAMPLE), '--ros-args', '-r', f'__ns:={namespace}',
             '-p', f'kp:={KP}', '-p', f'kd:={KD}', '-p', f'torque_limit:={LIMIT}'],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
            env={**os.environ, 'PYTHONUNBUFFERED': '1'})
        last = (TICKS - 1) * TICK_NS
        assert harness.spin_until(lambda: bool(odom) and max(
            m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in odom[-5:]) >= last,
            timeout=120.0), f'{len(odom)} ticks recorded'
    finally:
        code, stderr = stop_with_sigint(node)
        stop_controller(controller)
    assert_every_tick_answered(code, stderr)
    found: dict[int, np.ndarray] = {}
    for message in odom:
        q = message.pose.pose.orientation
        assert (message.header.frame_id, message.child_frame_id) == ('world', 'base_link')
        found.setdefault(message.header.stamp.sec * 10**9 + message.header.stamp.nanosec,
                         np.array([q.w, q.x, q.y, q.z]))
    assert all(k * TICK_NS in found for k in range(TICKS))
    reference = DynamicsPropagator(scene_from_mapping(scene({'attitude_pd': {
        'kp': KP, 'kd': KD, 'torque_limit': LIMIT, 'control_period': TICK_NS * 1e-9}})))
    worst = 0.0
    for k in range(TICKS):
        if k:
            reference.advance_to(k * TICK_NS * 1e-9)
        worst = max(worst, attitude_error(found[k * TICK_NS],
                                          np.asarray(reference.state.attitude)))
    assert worst <= 1e-9, worst
    assert attitude_error(found[last], np.array([1.0, 0.0, 0.0, 0.0])) < attitude_error(
        found[0], np.array([1.0, 0.0, 0.0, 0.0])) - 0.1  # it slewed toward the identity
