"""What the node and the replay tool share besides the sessions: timing and the scene.

* The node's name, the diagnostics period and the output timer period
  :func:`timer_period_ns` of ``publish_rate`` (what
  ``rclpy.node.Node.create_timer(1 / publish_rate)`` uses); an rcl timer on a clock that
  starts at 0 (``use_sim_time`` before the first ``/clock``) fires at the multiples of the
  period, reading the clock when it runs. The topics are
  :mod:`rigid_body_attitude.session.interface`'s.
* :func:`load_node_scene`: the scene with the ``integrator``, ``step`` and ``torque_timeout``
  overrides, its topics checked against the node's; :func:`open_session`: the session of a
  scene's rate source.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from rigid_body_attitude.core.dynamics.scene import Scene, load_scene
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.session.base import OutputSink
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.filtered_gyro import FilteredGyroSession
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.interface import check_scene_topics

__all__ = ['AnySession', 'COMMAND_EFFECTS', 'DIAGNOSTICS_PERIOD', 'NODE_NAME', 'load_node_scene',
           'open_session', 'timer_period_ns']

NODE_NAME = 'attitude_propagator'

#: Seconds between diagnostics messages.
DIAGNOSTICS_PERIOD = 1.0
#: Effects whose ``timeout`` the ``torque_timeout`` parameter overrides.
COMMAND_EFFECTS = ('commanded_torque', 'commanded_force', 'rotor', 'reaction_wheels',
                   'magnetorquers')

#: A session of either rate source (what :func:`open_session` returns).
AnySession = GyroSession | DynamicsSession


def timer_period_ns(publish_rate: float) -> int:
    """Timer period [ns] of ``create_timer(1.0 / publish_rate)`` (rclpy truncates to ns)."""
    return int(float(1.0 / publish_rate) * 1e9)


def load_node_scene(scene: str, integrator: str = '', step: float = 0.0,
                    torque_timeout: float = 0.0) -> Scene:
    """The scene as the node loads it: integrator, step and command timeout overridden.

    Empty or zero values keep the scene's own; raises the project's errors for a bad scene
    (:class:`~rigid_body_attitude.core.errors.SceneError` for a topic it names that is one of
    the node's own: :func:`~.interface.check_scene_topics`).
    """
    held = {'timeout': torque_timeout} if torque_timeout > 0.0 else {}
    loaded = load_scene(scene).with_overrides(
        integrator=integrator, step=step,
        effect_parameters={name: held for name in COMMAND_EFFECTS} if held else None)
    try:
        check_scene_topics(loaded)
    except SceneError as err:
        if not loaded.source:
            raise
        raise SceneError(f'Scene file {loaded.source!r}: {err}') from err
    return loaded


def open_session(scene: Scene, values: Mapping[str, Any], sink: OutputSink,
                 clock_ns: Callable[[], int], monotonic: Callable[[], float]) -> AnySession:
    """The session of the scene's rate source (see :class:`~.base.Session`)."""
    if scene.rate_source != 'gyro':
        return DynamicsSession(scene, values, sink, clock_ns, monotonic)
    kind = GyroSession if scene.estimation is None else FilteredGyroSession
    return kind(scene, values, sink, clock_ns, monotonic)
