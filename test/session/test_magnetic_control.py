"""The controller's torque rods without ROS (session/magnetic_control.py, magnetic_ticks.py):
B-dot and momentum dumping on the measured field, the sample each tick uses and waits for,
the mount, and every bad magnetic input refused and counted by reason.

The dipoles are compared bit for bit with the laws (core/control/magnetic.py) called directly.
"""

from __future__ import annotations

import math

import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.control.magnetic import bdot_dipole, dumping_dipole
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.msgs.tf_message import Transform
from rigid_body_attitude.session.controller import ControllerSession
from rigid_body_attitude.session.controller_parameters import (
    check_controller_values, controller_defaults)
from rigid_body_attitude.session.magnetic_control import (
    MAX_KEPT, MIN_FIELD, magnetic_control)
from rigid_body_attitude.session.magnetic_ticks import MAX_PARKED
from rigid_body_attitude.session.settings import load_node_scene
from rigid_body_attitude.session.wheel_drive import WheelDrive

MS = 1_000_000
SECOND = 1_000_000_000
BDOT = {'actuator': 'magnetorquers', 'bdot_gain': 4e5, 'magnetometer_period': 0.1}
MOUNT = quat.from_rpy([0.0, 0.0, math.pi / 2])  # the shipped scene's magnetometer, yawed 90°


class Sink:
    """Records torques, dipoles, reports and log lines."""

    def __init__(self):
        self.torques, self.dipoles, self.reports, self.logs = [], [], [], []

    def torque(self, sec, nanosec, torque_body):
        self.torques.append((sec * SECOND + nanosec, torque_body))

    def dipole(self, sec, nanosec, dipole_body):
        self.dipoles.append((sec * SECOND + nanosec, dipole_body))

    def diagnostics(self, report):
        self.reports.append(report)

    def log(self, level, text):
        self.logs.append((level, text))


def controller(**overrides):
    values = {**controller_defaults(), **overrides}
    assert check_controller_values(values) == ''
    loaded = load_node_scene(values['scene']) if values['scene'] else None
    drive = WheelDrive(loaded) if values['actuator'] == 'reaction_wheels' else None
    sink = Sink()
    return ControllerSession(values, sink, lambda: 0.0,
                             magnetic_control(values, loaded, drive)), sink


def field_at(stamp_ns):
    """A field [T] in the sensor frame, different at every stamp."""
    t = stamp_ns * 1e-9
    return (2e-5 * math.cos(0.3 * t), 1.5e-5 * math.sin(0.7 * t) + 1e-6, -3e-5 + 1e-6 * t)


def body(field):
    """The sensor frame's field in body axes (the 90° yaw mount)."""
    return quat.rotate_floats(tuple(MOUNT.tolist()), field)


def tick(session, stamp_ns):
    sec, nanosec = divmod(stamp_ns, SECOND)
    session.orientation(sec, nanosec, 'world', (1.0, 0.0, 0.0, 0.0))
    session.twist(sec, nanosec, 'base_link', (0.1, 0.0, 0.0))


def sample(session, stamp_ns, frame='magnetometer_link', field=None):
    session.magnetometer(*divmod(stamp_ns, SECOND), frame,
                         field_at(stamp_ns) if field is None else field)


def mount_transform(session):
    w, x, y, z = MOUNT.tolist()
    session.transforms([Transform(0, 0, 'base_link', 'magnetometer_link', (0.0, 0.0, 0.0),
                                  (w, x, y, z))])


def test_bdot_is_the_law_on_the_samples_of_two_recomputations_in_body_axes():
    session, sink = controller(**BDOT, control_period=1.0)
    mount_transform(session)
    for k in range(31):  # ticks every 100 ms, a sample at each (P = 0.1 s)
        sample(session, k * 100 * MS)
        tick(session, k * 100 * MS)
    assert [stamp for stamp, _ in sink.dipoles] == [k * 100 * MS for k in range(31)]
    assert sink.torques == []  # B-dot alone: no torque
    expected = {0: (0.0, 0.0, 0.0)}  # no previous sample at the first
    for n in (1, 2, 3):
        expected[n] = bdot_dipole(body(field_at(n * SECOND)), body(field_at((n - 1) * SECOND)),
                                  1.0, 4e5)
    for stamp, dipole in sink.dipoles:
        assert dipole == expected[stamp // SECOND]  # recomputed each second, held between


def test_a_tick_waits_for_its_sample_stamped_floor_t_over_p_times_p():
    """Ticks every 50 ms, samples every 100 ms: the tick at 150 ms uses the 100 ms sample; a
    tick whose sample has not come is answered when it comes, and the answers do not depend
    on the order the inputs came in."""
    runs = []
    for order in ('samples first', 'ticks first'):
        session, sink = controller(**BDOT, magnetometer_mount_rpy=(0.0, 0.0, math.pi / 2))
        for k in range(12):
            stamp_ns = k * 50 * MS
            if order == 'samples first' and k % 2 == 0:
                sample(session, stamp_ns)
            tick(session, stamp_ns)
            if order == 'ticks first' and k % 2 == 0:
                assert len(sink.dipoles) == k  # tick k waits for its sample
                sample(session, stamp_ns)
            assert len(sink.dipoles) == k + 1
        runs.append(sink.dipoles)
    assert runs[0] == runs[1]
    session_dipoles = dict(runs[0])
    # recomputed at every tick (control_period 0), a new sample every other tick: held at the
    # ticks between
    assert session_dipoles[150 * MS] == session_dipoles[100 * MS] == bdot_dipole(
        body(field_at(100 * MS)), body(field_at(0)), 0.1, 4e5)


def test_the_mount_from_tf_static_is_waited_for_and_the_parameter_needs_none():
    session, sink = controller(**BDOT)
    sample(session, 0)
    tick(session, 0)
    assert sink.dipoles == []
    sink.reports.clear()
    session.publish_diagnostics()
    assert "waiting for the static transform 'base_link' -> 'magnetometer_link'" in (
        sink.reports[-1].message)
    mount_transform(session)
    assert sink.dipoles == [(0, (0.0, 0.0, 0.0))]
    sample(session, 100 * MS)
    tick(session, 100 * MS)
    assert sink.dipoles[-1][1] == bdot_dipole(body(field_at(100 * MS)), body(field_at(0)),
                                              0.1, 4e5)
    # samples in body_frame need no mount
    session, sink = controller(**BDOT)
    sample(session, 0, frame='base_link')
    tick(session, 0)
    assert sink.dipoles == [(0, (0.0, 0.0, 0.0))]


def test_dumping_is_the_cross_product_law_on_the_wheels_state_of_the_tick():
    session, sink = controller(actuator='reaction_wheels', scene='wheel_slew_commanded',
                               dumping_gain=0.001, kp=0.4, kd=4.0)
    drive = WheelDrive(load_node_scene('wheel_slew_commanded'))
    names = ('wheel_d', 'wheel_c', 'wheel_b', 'wheel_a')  # any order
    speeds = {'wheel_a': 150.0, 'wheel_b': -100.0, 'wheel_c': 120.0, 'wheel_d': -60.0}
    mount_transform(session)
    sample(session, 0)
    tick(session, 0)
    assert sink.torques == [] and sink.dipoles == []  # waits for wheels/state
    session.wheel_state(0, 0, names, tuple(speeds[name] for name in names))
    stored = drive.stored_momentum(tuple(speeds[name] for name in drive.names))
    assert sink.dipoles == [(0, dumping_dipole(stored, body(field_at(0)), 0.001))]
    assert len(sink.torques) == 1


def test_parameters_and_scenes_that_cannot_give_a_dipole_are_refused():
    values = controller_defaults()
    assert 'bdot_gain` > 0' in check_controller_values(values | {'actuator': 'magnetorquers'})
    assert '`actuator` reaction_wheels with parameter `dumping_gain`' in (
        check_controller_values(values | {'dumping_gain': 0.1}))
    bdot = values | BDOT | {'magnetometer_period': 0.0}
    with pytest.raises(InputError, match='magnetometer_period` > 0 or a `scene`'):
        magnetic_control(bdot, None, None)
    assert magnetic_control(bdot, load_node_scene('bdot_detumbling_commanded'),
                            None).period_ns == 100 * MS  # the scene's 10 Hz magnetometer
    with pytest.raises(InputError, match="scene 'bdot_detumbling' to have magnetorquers that "
                                         'take dipole commands'):
        magnetic_control(bdot, load_node_scene('bdot_detumbling'), None)


@pytest.mark.parametrize('call, reason', [
    (lambda s: s.magnetometer(0, 0, 'base_link', (math.nan, 0.0, 0.0)), 'non_finite'),
    (lambda s: s.magnetometer(0, 0, 'base_link', (2.0, 0.0, 0.0)), 'out_of_range'),
    (lambda s: s.magnetometer(0, 0, 'base_link', (0.0, 0.0, 0.0)), 'out_of_range'),
    (lambda s: s.magnetometer(0, 0, 'base_link', (1e-160, 0.0, -1e-160)), 'out_of_range'),
    (lambda s: s.magnetometer(0, 0, 'base_link', (0.99e-9, 0.0, 0.0)), 'out_of_range'),
    (lambda s: s.magnetometer(-1, 0, 'base_link', (0.0, 0.0, 0.0)), 'invalid_stamp'),
    (lambda s: s.wheel_state(0, 2 * SECOND, ('wheel_a',), (1.0,)), 'invalid_stamp'),
    (lambda s: s.wheel_state(0, 0, ('wheel_a', 'wheel_b', 'wheel_c', 'wheel_x'), (0.0,) * 4),
     'unknown_wheel'),
    (lambda s: s.wheel_state(0, 0, ('wheel_a', 'wheel_a', 'wheel_c', 'wheel_d'), (0.0,) * 4),
     'unknown_wheel'),
    (lambda s: s.wheel_state(0, 0, ('wheel_a', 'wheel_b'), (0.0,) * 2), 'missing_wheel'),
    (lambda s: s.wheel_state(0, 0, ('wheel_a', 'wheel_b', 'wheel_c', 'wheel_d'), (0.0,) * 3),
     'wheel_lengths'),
    (lambda s: s.wheel_state(0, 0, ('wheel_a', 'wheel_b', 'wheel_c', 'wheel_d'),
                             (0.0, math.inf, 0.0, 0.0)), 'non_finite'),
    (lambda s: s.transforms([Transform(0, 0, 'base_link', 'mag', (0.0,) * 3,
                                       (0.0, 0.0, 0.0, 0.0))]), 'tf_denormalized'),
    (lambda s: s.malformed('imu/mag', 'truncated'), 'malformed'),
])
def test_bad_magnetic_inputs_are_refused_counted_and_change_nothing(call, reason):
    session, sink = controller(actuator='reaction_wheels', scene='wheel_slew_commanded',
                               dumping_gain=0.001)
    call(session)
    assert dict(session.rejections) == {reason: 1}
    assert session.magnetic.fields == {} and session.magnetic.speeds == {}
    assert any(reason in text for _, text in sink.logs)


def test_a_flood_of_far_future_samples_keeps_the_ones_ticks_need_and_ticks_stay_bounded():
    session, sink = controller(**BDOT, magnetometer_mount_rpy=(0.0, 0.0, 0.0))
    sample(session, 0)
    for k in range(MAX_KEPT + 10):
        sample(session, (2**31 - 1 - k) * SECOND, field=(1e-5, 0.0, 0.0))
    assert session.rejections['unpaired'] == 11  # the newest-stamped dropped
    tick(session, 0)
    assert sink.dipoles == [(0, (0.0, 0.0, 0.0))]
    for k in range(1, MAX_PARKED + 6):  # ticks whose samples never come
        tick(session, k * 100 * MS)
    assert len(session.parked) == MAX_PARKED
    assert session.rejections['unpaired'] == 11 + 5


def test_the_weakest_field_taken_gives_a_finite_dumping_dipole():
    """A field whose largest component is MIN_FIELD is taken; one of 1e-160 T (refused) would
    give dumping's ``k / |B|²`` = inf, and a NaN or infinite dipole."""
    assert not all(math.isfinite(v) for v in dumping_dipole((0.0, 0.01, 0.02),
                                                            (1e-160, 0.0, 0.0), 0.001))
    session, sink = controller(actuator='reaction_wheels', scene='wheel_slew_commanded',
                               dumping_gain=1e6, kp=0.5)
    names = session.magnetic.drive.names
    session.wheel_state(0, 0, names, (600.0, -600.0, 600.0, -600.0))
    session.magnetometer(0, 0, 'base_link', (MIN_FIELD, 0.0, 0.0))
    tick(session, 0)
    assert not session.rejections and len(sink.dipoles) == 1
    assert all(math.isfinite(v) for v in sink.dipoles[0][1])


def test_repeated_and_stale_stamps_are_counted_and_never_change_an_answered_tick():
    """A second, different sample of one stamp replaces the first (counted); one of a stamp a
    tick used is refused; one stamped before what the last tick used is counted when
    dropped unused; an equal one changes nothing."""
    session, sink = controller(**BDOT, magnetometer_mount_rpy=(0.0, 0.0, 0.0))
    sample(session, 0, field=(9e-5, 9e-5, 9e-5))
    sample(session, 0)  # replaces the first
    sample(session, 0)  # equal: nothing counted
    assert dict(session.rejections) == {'repeated_stamp': 1}
    tick(session, 0)
    sample(session, 0, field=(5e-5, 0.0, 0.0))  # the sample tick 0 used: refused
    assert session.magnetic.fields[0][1] == field_at(0)
    sample(session, 100 * MS)
    tick(session, 100 * MS)
    sample(session, 50 * MS)  # before tick 100 ms's sample: stale, kept while no tick goes back
    assert session.rejections['stale_stamp'] == 0
    sample(session, 200 * MS)
    tick(session, 200 * MS)
    assert dict(session.rejections) == {'repeated_stamp': 2, 'stale_stamp': 1}
    assert sink.dipoles[1] == (100 * MS, bdot_dipole(field_at(100 * MS), field_at(0), 0.1,
                                                     4e5))


def test_a_plant_restarting_uses_the_samples_stamped_before_the_last_tick():
    session, sink = controller(**BDOT, magnetometer_mount_rpy=(0.0, 0.0, 0.0))
    for k in range(3):
        sample(session, k * 100 * MS)
        tick(session, k * 100 * MS)
    sample(session, 0, field=(3e-5, 0.0, 0.0))  # the restarted plant's first sample
    tick(session, 0)
    sample(session, 100 * MS, field=(3e-5, 1e-5, 0.0))
    tick(session, 100 * MS)
    assert session.time_jumps_back == 1
    assert sink.dipoles[-1] == (100 * MS, bdot_dipole((3e-5, 1e-5, 0.0), (3e-5, 0.0, 0.0),
                                                      0.1, 4e5))
    assert 'stale_stamp' not in session.rejections


def test_a_tick_whose_sample_never_gets_a_mount_is_counted_no_mount():
    session, sink = controller(**BDOT)
    sample(session, 0, frame='map')
    tick(session, 0)
    assert sink.dipoles == [] and 'map' in session.report().message
    sample(session, 100 * MS, frame='base_link')
    tick(session, 100 * MS)
    assert [stamp for stamp, _ in sink.dipoles] == [100 * MS]
    assert dict(session.rejections) == {'no_mount': 1}
