"""Wheel commands (JointState), the dipole and the wheels' state, through the session without
ROS: checks by reason, the array's order, lockstep, the state output, the diagnostics."""

from __future__ import annotations

import math

import pytest

from rigid_body_attitude.msgs.cdr import encode_vector3_stamped
from rigid_body_attitude.msgs.joint_state import decode_joint_state, joint_state_encoder
from rigid_body_attitude.session.decoding import input_handler
from rigid_body_attitude.session.interface import NODE_INTERFACE, Situation
from rigid_body_attitude.session.reports import LEVEL_OK, LEVEL_WARN

PERIOD_NS = 50_000_000  # 20 Hz: one tick per step of the scene
NAMES = ('wheel_a', 'wheel_b', 'wheel_c', 'wheel_d')


def wheel_session(open_scene, **parameters):
    return open_scene('wheel_slew_commanded', publish_rate=20.0, **parameters)


def stamp(nanoseconds):
    return divmod(nanoseconds, 10**9)


def tick(session, clocks, now_ns):
    """A tick of the node clock at ``now_ns`` (commands are checked against that clock)."""
    clocks.now_ns = now_ns
    session.tick(now_ns)


def values(report):
    return dict(report.values)


def test_the_scene_has_the_wheel_and_dipole_topics_and_lockstep_waits_for_both(open_scene):
    session, _ = wheel_session(open_scene, lockstep=True)
    situation = Situation(session.scene, {}, session.propagator.input_names)
    inputs = [endpoint.name for endpoint in NODE_INTERFACE.inputs(situation, ('command',))]
    outputs = [endpoint.name for endpoint in NODE_INTERFACE.outputs(situation)]
    assert 'wheels/command' in inputs and 'dipole' in inputs and 'torque' not in inputs
    assert 'wheels/state' in outputs
    assert session.command_inputs == ('dipole', 'wheels/command')
    session.lockstep_tick(0)
    session.wheel_command(0, 0, NAMES, (), (), (0.0,) * 4)
    assert not session.lockstep_answered()
    session.dipole(0, 0, (0.0, 0.0, 0.0))
    assert session.lockstep_answered()
    session.wheel_command(0, 0, NAMES, (), (1.0,) * 4, ())  # a second one for the tick
    assert session.rejection_counts()['stale_stamp'] == 1


def test_a_scene_whose_wheels_a_controller_of_its_own_drives_takes_no_command(open_scene):
    session, _ = open_scene('wheel_slew', publish_rate=20.0)
    situation = Situation(session.scene, {}, session.propagator.input_names)
    names = [endpoint.name for endpoint in NODE_INTERFACE.present(situation)]
    assert 'wheels/command' not in names and 'dipole' not in names
    assert 'wheels/state' in names


@pytest.mark.parametrize('fields, reason', [
    ((('wheel_a', 'wheel_b', 'wheel_c', 'wheel_x'), (), (), (0.0,) * 4), 'unknown_wheel'),
    ((('wheel_a', 'wheel_a', 'wheel_c', 'wheel_d'), (), (), (0.0,) * 4), 'unknown_wheel'),
    ((('wheel_a', 'wheel_b', 'wheel_c'), (), (), (0.0,) * 3), 'missing_wheel'),
    ((NAMES, (), (1.0,) * 4, (0.0,) * 4), 'wheel_fields'),
    ((NAMES, (), (), ()), 'wheel_fields'),
    ((NAMES, (0.0,) * 4, (), (0.0,) * 4), 'wheel_fields'),
    ((NAMES, (), (), (0.0,) * 3), 'wheel_lengths'),
    ((NAMES, (), (math.nan, 0.0, 0.0, 0.0), ()), 'non_finite'),
    ((NAMES, (), (), (1e13, 0.0, 0.0, 0.0)), 'out_of_range'),
])
def test_a_bad_wheel_command_is_refused_by_reason_and_changes_nothing(open_scene, clocks,
                                                                      fields, reason):
    session, sink = wheel_session(open_scene)
    twin, twin_sink = wheel_session(open_scene)
    for run in (session, twin):
        run.tick(0)
    session.wheel_command(0, 1, *fields)
    clocks.monotonic += 10.0
    for run in (session, twin):
        run.tick(PERIOD_NS * 20)
    assert session.rejection_counts()[reason] == 1
    assert session.commands_accepted == 0
    assert sink.ticks[-1][2] == twin_sink.ticks[-1][2]
    assert sink.wheel_states[-1] == twin_sink.wheel_states[-1]
    assert any(level == LEVEL_WARN and 'wheel' in text for level, text in sink.logs)
    report = session.report()
    assert report.level >= LEVEL_WARN and reason in report.message
    assert values(report)[f'rejected {reason}'] == '1' or reason in (
        'non_finite', 'out_of_range')


def test_a_command_in_any_order_of_names_drives_the_wheels_in_the_arrays_order(open_scene, clocks):
    """Speeds in reversed name order; the servo drives each wheel to its own speed."""
    session, sink = wheel_session(open_scene)
    targets = {'wheel_a': 152.0, 'wheel_b': -98.0, 'wheel_c': 118.0, 'wheel_d': -62.0}
    tick(session, clocks, 0)
    names = tuple(reversed(NAMES))
    session.wheel_command(0, 1, names, (), tuple(targets[name] for name in names), ())
    for k in range(1, 201):  # 10 s: the servo (5/s) and the torque limit settle
        tick(session, clocks, k * PERIOD_NS)
        session.wheel_command(*stamp(k * PERIOD_NS + 1), names,
                              (), tuple(targets[name] for name in names), ())
    state = decode_joint_state(sink.wheel_states[-1])
    assert state.names == NAMES and state.frame_id == ''
    assert (state.sec, state.nanosec) == divmod(200 * PERIOD_NS, 10**9)
    speeds = session.wheels.effect.speeds()
    assert state.velocity == tuple(speeds)
    for name, speed in zip(NAMES, speeds):
        # the steady friction leaves (c + v Ω)/(J k): 4e-3 rad/s and less
        assert abs(speed - targets[name]) < 0.01
    assert all(-math.pi <= angle <= math.pi for angle in state.position)
    assert state.effort == tuple(session.wheels.effect.motor)


def test_the_speed_limit_is_said_per_wheel_in_the_diagnostics_and_the_log(open_scene, clocks):
    session, sink = wheel_session(open_scene)
    tick(session, clocks, 0)
    torques = (0.02, 0.0, 0.0, 0.0)  # wheel_a from 150 rad/s to its 600 rad/s limit in 225 s
    for k in range(1, 4700):
        session.wheel_command(*stamp(k * PERIOD_NS - 1), NAMES, (), (), torques)
        tick(session, clocks, k * PERIOD_NS)
    effect = session.wheels.effect
    # at the limit the cut motor lets friction slow the wheel below it, then drives it back:
    # each return is an episode
    episodes = effect.speed_limit_episodes[0]
    assert episodes >= 1 and effect.speed_limit_episodes[1:] == [0, 0, 0]
    assert effect.speed_limited_time[0] > 0.0 and effect.speed_limited_time[1:] == [0.0] * 3
    report = session.report()
    shown = values(report)
    assert report.level == LEVEL_WARN and 'wheel_a at its speed limit' in report.message
    assert float(shown['wheel_a speed [rad/s]']) == pytest.approx(600.0, abs=0.5)
    assert shown['wheel_a speed limit episodes'] == str(episodes)
    assert float(shown['wheel_a at speed limit [s]']) == pytest.approx(
        effect.speed_limited_time[0])
    assert any('wheel_a at the speed limit' in text for _, text in sink.logs)
    assert shown['reaction_wheels.speed_limit'] == str(episodes)
    clocks.monotonic += 1.0
    session.wheel_command(*stamp(4700 * PERIOD_NS - 1), NAMES, (), (), (-0.02, 0.0, 0.0, 0.0))
    tick(session, clocks, 4700 * PERIOD_NS)  # the step up to it began at the limit, cut
    assert 'wheel_a at its speed limit for 0.05 s' in session.report().message
    tick(session, clocks, 4701 * PERIOD_NS)
    assert 'speed limit' not in session.report().message


def test_the_handler_decodes_joint_states_and_the_dipole(open_scene, clocks):
    session, sink = wheel_session(open_scene)
    tick(session, clocks, 0)
    wheels = input_handler(session, 'wheels/command')
    dipole = input_handler(session, 'dipole')
    wheels(joint_state_encoder('', NAMES)(0, 1, (), (), (0.001, 0.0, 0.0, -0.001)))
    wheels(b'\x00\x01\x00\x00garbage')
    dipole(encode_vector3_stamped(2, 'base_link', (1.0, 0.0, 0.0)))
    tick(session, clocks, PERIOD_NS * 2)
    assert session.commands_accepted == 2
    assert session.malformed_by_topic['wheels/command'] == 1
    assert session.rods.effect.dipole == pytest.approx((1.0, 0.0, 0.0))
    report = session.report()
    assert values(report)['magnetorquers dipole [A m2]'].startswith('1 ')


def test_momentum_and_energy_published_include_the_wheels(open_scene):
    """The body starts at rest: the published energy is the wheels' spin energy alone."""
    session, sink = wheel_session(open_scene)
    session.tick(0)
    effect = session.wheels.effect
    energy = sink.invariant_samples[-1][2]
    assert energy == pytest.approx(effect.kinetic_energy(), rel=1e-12)
    assert session.report().level == LEVEL_OK


def test_a_plain_scene_publishes_no_wheel_state(open_scene):
    session, sink = open_scene('commanded_torque', publish_rate=20.0)
    session.tick(0)
    session.tick(PERIOD_NS)
    assert sink.wheel_states == [] and session.wheels is None
    assert not any('wheel' in key for key, _ in session.report().values)


def test_a_reset_restores_the_wheels(open_scene):
    session, sink = wheel_session(open_scene)
    session.tick(0)
    first = decode_joint_state(sink.wheel_states[-1])
    session.wheel_command(0, 1, NAMES, (), (), (0.02,) * 4)
    session.tick(PERIOD_NS * 10)
    session.reset()
    session.tick(PERIOD_NS * 11)
    assert decode_joint_state(sink.wheel_states[-1]).velocity == first.velocity
