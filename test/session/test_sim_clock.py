"""The sim clock and the lockstep command rule, without ROS (the session and SimClock)."""

from __future__ import annotations

import math

import pytest
from conftest import RecordingSink

from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.session.reports import LEVEL_WARN
from rigid_body_attitude.session.settings import load_node_scene
from rigid_body_attitude.session.sim_clock import SimClock, sim_clock_problem

PERIOD_NS = 10_000_000  # 100 Hz
TORQUE = (0.0, 0.0, 0.01)


class WallClock:
    """A monotonic clock the test moves."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def lockstep_session(open_scene):
    session, sink = open_scene('commanded_torque', lockstep=True, publish_rate=100.0)
    return session, sink


def split(nanoseconds):
    return divmod(nanoseconds, 10**9)


def test_a_command_counts_only_when_stamped_with_the_current_tick(open_scene):
    session, sink = lockstep_session(open_scene)
    session.lockstep_tick(0)
    assert not session.lockstep_answered()
    session.wrench(0, 0, (0.0, 0.0, 0.0), TORQUE)  # t_0 = 0 is a real stamp in lockstep
    assert session.lockstep_answered()
    session.wrench(0, 0, (0.0, 0.0, 0.0), TORQUE)  # twice for one tick
    assert session.rejection_counts()['stale_stamp'] == 1
    session.lockstep_tick(PERIOD_NS)
    assert not session.lockstep_answered()
    session.wrench(*split(2 * PERIOD_NS), (0.0, 0.0, 0.0), TORQUE)  # the future
    session.wrench(0, 5, (0.0, 0.0, 0.0), TORQUE)  # older than the tick
    counts = session.rejection_counts()
    assert (counts['future_stamp'], counts['stale_stamp']) == (1, 2)
    assert not session.lockstep_answered()
    session.wrench(*split(PERIOD_NS), (0.0, 0.0, 0.0), TORQUE)
    assert session.lockstep_answered()
    assert session.commands_accepted == 2
    report = session.report()
    assert report.level >= LEVEL_WARN and 'future_stamp' in report.message
    assert '`lockstep`' in report.message


def test_the_command_answering_tick_k_is_held_over_the_step_to_tick_k_plus_1(open_scene):
    """Zero-order hold: the torque stamped t_k acts on [t_k, t_k+1), not before t_k."""
    session, sink = lockstep_session(open_scene)
    twin, _ = lockstep_session(open_scene)
    session.lockstep_tick(0)
    session.wrench(0, 0, (0.0, 0.0, 0.0), TORQUE)
    session.lockstep_tick(PERIOD_NS)
    # The same torque applied by the propagator over exactly [0, P].
    twin.lockstep_tick(0)
    twin.propagator.command('torque', 0.0, TORQUE)
    twin.propagator.advance_to(PERIOD_NS * 1e-9)
    assert sink.ticks[-1][2].omega_body == tuple(twin.propagator.state.omega_tuple())
    # ω_z = M_z P / J_zz exactly as the hold says (J_zz = m (a² + b²) / 12).
    j_zz = 2.0 * (0.1**2 + 0.2**2) / 12.0
    assert math.isclose(sink.ticks[-1][2].omega_body[2], TORQUE[2] * 0.01 / j_zz,
                        rel_tol=1e-12)


def test_the_clock_ticks_from_zero_paces_and_reports_its_factor():
    wall = WallClock()
    clock = SimClock(PERIOD_NS, 5.0, True, 0.5, wall)
    assert clock.next_tick() == 0
    assert math.isclose(clock.seconds_to_next(), 0.002)  # 10 ms of sim time at 5x
    wall.now += 0.002
    assert clock.next_tick() == PERIOD_NS
    wall.now += 1.0  # far behind: the schedule moves, no burst
    assert clock.seconds_to_next() == 0.0
    clock.next_tick()
    assert math.isclose(clock.seconds_to_next(), 0.002)
    sink = RecordingSink()
    clock.timed_out(sink)
    clock.timed_out(sink)
    assert len(sink.logs) == 1 and 'lockstep_timeout' in sink.logs[0][1]  # once per silence
    clock.answered()
    clock.timed_out(sink)
    assert len(sink.logs) == 2 and clock.timeouts == 3

    class Counts:
        clock_values = ()
        clock_problems = ()
    counts = Counts()
    clock.report(counts)
    values = dict(counts.clock_values)
    assert values['lockstep_timeouts'] == '3'
    # 20 ms of sim time over 1.002 s of wall time since the first tick
    assert values['achieved_real_time_factor'] == f'{0.02 / 1.002:.3g}' == '0.02'
    assert 'lockstep_timeout' in counts.clock_problems[0]
    clock.report(counts)
    assert counts.clock_problems == ()  # no new timeout in this period


def test_an_unpaced_clock_is_always_due():
    clock = SimClock(PERIOD_NS, 0.0, False, 1.0, WallClock())
    clock.next_tick()
    assert clock.seconds_to_next() == 0.0


@pytest.mark.parametrize('scene, values, text', [
    ('strapdown', {'publish_clock': True}, 'dynamics scene'),
    ('torque_free_box', {'lockstep': True}, 'commanded inputs'),
])
def test_sim_clock_parameters_that_do_not_fit_the_scene_are_refused(scene, values, text):
    loaded: Scene = load_node_scene(scene, '', 0.0, 0.0)
    assert text in sim_clock_problem(values, loaded, ())
    assert sim_clock_problem({'publish_clock': True}, load_node_scene(
        'torque_free_box', '', 0.0, 0.0), ()) == ''
