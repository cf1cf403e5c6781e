"""The controller's logic without ROS (session/controller.py, session/controller_parameters.py):
one torque per tick stamped like the tick, sample and hold at the control period, targets in
force by stamp, and every bad input rejected and counted by reason.

The torques are compared bit for bit with the law (core/control) called directly: the session
must add nothing to it.
"""

from __future__ import annotations

import math

import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.control import pd_torque_floats
from rigid_body_attitude.session.controller import ControllerSession, MAX_PENDING
from rigid_body_attitude.session.controller_parameters import (
    check_controller_values, controller_defaults)

MS = 1_000_000
SECOND = 1_000_000_000


class Sink:
    """Records torques, reports and log lines."""

    def __init__(self):
        self.torques, self.reports, self.logs = [], [], []

    def torque(self, sec, nanosec, torque_body):
        self.torques.append((sec * SECOND + nanosec, torque_body))

    def diagnostics(self, report):
        self.reports.append(report)

    def log(self, level, text):
        self.logs.append((level, text))


def session(**overrides):
    values = {**controller_defaults(), **overrides}
    assert check_controller_values(values) == ''
    sink = Sink()
    return ControllerSession(values, sink, lambda: 0.0), sink


def attitude_at(stamp_ns):
    """A slowly turning attitude, different at every stamp."""
    return tuple(quat.exp([0.3 + stamp_ns * 1e-9, -0.2, 0.1]).tolist())


def rate_at(stamp_ns):
    return (0.1, -0.05 + stamp_ns * 1e-10, 0.2)


def tick(controller, stamp_ns, twist_first=False):
    sec, nanosec = divmod(stamp_ns, SECOND)
    calls = [lambda: controller.orientation(sec, nanosec, 'world', attitude_at(stamp_ns)),
             lambda: controller.twist(sec, nanosec, 'base_link', rate_at(stamp_ns))]
    for call in (calls[::-1] if twist_first else calls):
        call()


def law(stamp_ns, target=(1.0, 0.0, 0.0, 0.0), kp=0.1, kd=0.04, limit=0.0):
    return pd_torque_floats(attitude_at(stamp_ns), rate_at(stamp_ns), target, (kp,) * 3,
                            (kd,) * 3, (limit,) * 3)


def test_each_tick_is_answered_once_with_its_own_stamp_and_the_law():
    controller, sink = session()
    stamps = [5 * SECOND + k * 10 * MS for k in range(20)]
    for k, stamp_ns in enumerate(stamps):
        tick(controller, stamp_ns, twist_first=k % 2 == 1)
    assert [stamp for stamp, _ in sink.torques] == stamps
    assert [torque for _, torque in sink.torques] == [law(stamp) for stamp in stamps]
    assert controller.computed == 20 and not controller.rejections


def test_an_input_alone_is_not_answered_until_its_partner_of_the_same_stamp_arrives():
    controller, sink = session()
    controller.orientation(1, 0, 'world', attitude_at(SECOND))
    controller.twist(1, 1, 'base_link', rate_at(SECOND))  # 1 ns later: another tick
    assert sink.torques == []
    # the next tick's orientation before the twist of tick 1 s: pairs are still found by stamp
    controller.orientation(1, 10 * MS, 'world', attitude_at(SECOND + 10 * MS))
    controller.twist(1, 0, 'base_link', rate_at(SECOND))
    controller.twist(1, 10 * MS, 'base_link', rate_at(SECOND + 10 * MS))
    assert [stamp for stamp, _ in sink.torques] == [SECOND, SECOND + 10 * MS]
    # the twist stamped 1 s + 1 ns never had a partner: dropped once a later tick was answered
    assert controller.rejections == {'unpaired': 1}


def test_control_period_holds_the_torque_and_restamps_it():
    controller, sink = session(control_period=0.05)
    stamps = [k * 10 * MS for k in range(12)]  # 0 .. 110 ms, ticks of 10 ms
    for stamp_ns in stamps:
        tick(controller, stamp_ns)
    assert [stamp for stamp, _ in sink.torques] == stamps
    computed_at = [0, 0, 0, 0, 0, 50, 50, 50, 50, 50, 100, 100]
    assert [torque for _, torque in sink.torques] == [law(k * MS) for k in computed_at]
    assert controller.computed == 3


def test_the_hold_follows_the_stamps_not_the_tick_count():
    # ticks of 30 ms with a period of 50 ms: recomputed at the first tick of each
    # [n 50 ms, (n+1) 50 ms): 0, 60, 120, 150
    controller, sink = session(control_period=0.05)
    for k in range(6):
        tick(controller, k * 30 * MS)
    computed_at = [0, 0, 60, 60, 120, 150]
    assert [torque for _, torque in sink.torques] == [law(k * MS) for k in computed_at]
    assert controller.computed == 4


def test_duplicates_stale_ticks_and_a_plant_restart():
    controller, sink = session()
    tick(controller, 2 * SECOND)
    tick(controller, 2 * SECOND)  # the same tick again: answered again, the same torque
    assert [stamp for stamp, _ in sink.torques] == [2 * SECOND, 2 * SECOND]
    assert sink.torques[1][1] == sink.torques[0][1] and controller.computed == 1
    assert controller.repeated == 1 and not controller.rejections
    tick(controller, SECOND)  # a complete pair from before: the plant restarted
    assert [stamp for stamp, _ in sink.torques] == [2 * SECOND, 2 * SECOND, SECOND]
    assert controller.time_jumps_back == 1


def test_saturation_and_target_parameters():
    controller, sink = session(torque_limit=0.001, target_rpy=(0.0, 0.0, 1.0))
    tick(controller, SECOND)
    target = tuple(quat.exp([0.0, 0.0, 1.0]).tolist())
    expected = law(SECOND, target, limit=0.001)
    assert sink.torques[0][1] == pytest.approx(expected, abs=1e-17)
    assert max(abs(value) for value in sink.torques[0][1]) == 0.001
    x, y, z, w = 0.0, 0.0, math.sin(0.5), math.cos(0.5)
    by_quaternion, sink_q = session(target_quaternion_xyzw=(x, y, z, w), torque_limit=0.001)
    tick(by_quaternion, SECOND)
    assert sink_q.torques[0][1] == pytest.approx(sink.torques[0][1], abs=1e-17)


def test_a_target_message_acts_from_its_stamp_on():
    controller, sink = session()
    sent = tuple(quat.exp([0.0, 0.5, 0.0]).tolist())
    controller.target_message(1, 20 * MS, 'world', sent)
    norm = math.sqrt(sum(value * value for value in sent))
    target = tuple(value / norm for value in sent)  # targets are normalised
    for k in range(4):
        tick(controller, SECOND + k * 10 * MS)
    assert [torque for _, torque in sink.torques] == [
        law(SECOND), law(SECOND + 10 * MS), law(SECOND + 20 * MS, target),
        law(SECOND + 30 * MS, target)]
    controller.target_message(1, 0, 'world', (1.0, 0.0, 0.0, 0.0))  # older than the one in force
    assert controller.rejections == {'stale_stamp': 1}


@pytest.mark.parametrize('call, reason', [
    (lambda c: c.orientation(1, 0, 'map', (1.0, 0.0, 0.0, 0.0)), 'wrong_frame'),
    (lambda c: c.twist(1, 0, 'world', (0.0, 0.0, 0.0)), 'wrong_frame'),
    (lambda c: c.target_message(1, 0, 'base_link', (1.0, 0.0, 0.0, 0.0)), 'wrong_frame'),
    (lambda c: c.orientation(1, 0, 'world', (math.nan, 0.0, 0.0, 0.0)), 'non_finite'),
    (lambda c: c.twist(1, 0, 'base_link', (0.0, math.inf, 0.0)), 'non_finite'),
    (lambda c: c.orientation(1, 0, 'world', (1.01, 0.0, 0.0, 0.0)), 'non_unit'),
    (lambda c: c.target_message(1, 0, 'world', (0.0, 0.0, 0.0, 0.0)), 'non_unit'),
    (lambda c: c.orientation(-1, 0, 'world', (1.0, 0.0, 0.0, 0.0)), 'invalid_stamp'),
    (lambda c: c.twist(1, 2 * SECOND, 'base_link', (0.0, 0.0, 0.0)), 'invalid_stamp'),
    (lambda c: c.malformed('twist', 'truncated: 20 of 100 bytes'), 'malformed'),
])
def test_bad_inputs_are_rejected_counted_and_warned(call, reason):
    controller, sink = session()
    call(controller)
    call(controller)
    assert controller.rejections == {reason: 2}
    assert len(sink.logs) == 1 and reason in sink.logs[0][1]  # throttled: one warning
    tick(controller, 3 * SECOND)  # the controller still works
    assert len(sink.torques) == 1


def test_pending_inputs_without_partner_are_bounded():
    controller, _ = session()
    for k in range(MAX_PENDING + 5):
        controller.orientation(1, k, 'world', (1.0, 0.0, 0.0, 0.0))
    assert controller.rejections == {'unpaired': 5}
    assert len(controller.pending['orientation']) == MAX_PENDING


def test_diagnostics_warn_while_no_tick_is_answered():
    controller, sink = session()
    controller.publish_diagnostics()
    assert sink.reports[-1].level == 1 and 'no tick answered' in sink.reports[-1].message
    tick(controller, SECOND)
    controller.publish_diagnostics()
    assert sink.reports[-1].level == 0 and sink.reports[-1].message == 'controlling'
    assert ('ticks answered', '1') in sink.reports[-1].values
    tick(controller, 2 * SECOND)
    controller.orientation(2, 5, 'map', (1.0, 0.0, 0.0, 0.0))
    controller.publish_diagnostics()
    assert sink.reports[-1].level == 1 and sink.reports[-1].message == '1 wrong_frame'
    assert ('rejected wrong_frame', '1') in sink.reports[-1].values


def test_odom_answers_its_tick_at_once_with_the_law_as_the_pair_does():
    by_odom, odom_sink = session()
    by_pair, pair_sink = session(state_input='orientation_twist')
    for stamp_ns in (0, 10 * MS, 20 * MS):
        sec, nanosec = divmod(stamp_ns, SECOND)
        by_odom.odometry(sec, nanosec, 'world', 'base_link', attitude_at(stamp_ns),
                         rate_at(stamp_ns))
        assert len(odom_sink.torques) == stamp_ns // (10 * MS) + 1  # answered at once
        tick(by_pair, stamp_ns)
    assert odom_sink.torques == pair_sink.torques
    assert odom_sink.torques[0][1] == pd_torque_floats(
        attitude_at(0), rate_at(0), (1.0, 0.0, 0.0, 0.0), (0.1,) * 3, (0.04,) * 3,
        (0.0,) * 3)


@pytest.mark.parametrize('frame, child, attitude, rate, reason', [
    ('map', 'base_link', (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 'wrong_frame'),
    ('world', 'imu', (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 'wrong_frame'),
    ('world', 'base_link', (1.1, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 'non_unit'),
    ('world', 'base_link', (math.nan, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0), 'non_finite'),
    ('world', 'base_link', (1.0, 0.0, 0.0, 0.0), (0.0, math.inf, 0.0), 'non_finite'),
])
def test_bad_odom_is_rejected_and_counted(frame, child, attitude, rate, reason):
    controller, sink = session()
    controller.odometry(1, 0, frame, child, attitude, rate)
    controller.malformed('odom', 'truncated')
    assert sink.torques == [] and controller.rejections == {reason: 1, 'malformed': 1}
    controller.publish_diagnostics()
    assert 'no tick answered: waiting for odom' in sink.reports[-1].message


@pytest.mark.parametrize('overrides, message', [
    ({'kp': -1.0}, 'Expected parameter `kp` to be a finite number in [0, 1e6], got -1.0'),
    ({'kd': 1}, 'Expected parameter `kd` to be a double'),
    ({'control_period': math.nan}, 'Expected parameter `control_period` to be a finite number'),
    ({'torque_limit': math.inf}, 'Expected parameter `torque_limit` to be a finite number'),
    ({'target_rpy': (0.0, 1.0)}, 'Expected parameter `target_rpy` to be a double array of 3'),
    ({'target_rpy': (0.0, 0.0, 1.0), 'target_quaternion_xyzw': (0.0, 0.0, 0.0, 1.0)},
     'Expected at most one of `target_rpy` and `target_quaternion_xyzw`, got both'),
    ({'target_quaternion_xyzw': (0.0, 0.0, 0.0, 0.5)},
     'Expected parameter `target_quaternion_xyzw` to have norm 1 (within 0.001), got norm 0.5'),
    ({'body_frame': 'world'}, 'Expected `world_frame` and `body_frame` to differ'),
    ({'gain': 1.0}, 'Unknown parameter `gain`'),
])
def test_bad_parameters_give_one_reason(overrides, message):
    assert message in check_controller_values(
        {**controller_defaults(), **overrides})
