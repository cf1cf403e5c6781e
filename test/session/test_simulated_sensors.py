"""A dynamics session with a simulated IMU, magnetometer and star tracker: each sampled at its
own instants inside the ticks, as MagneticField and PoseWithCovarianceStamped messages;
bit-identical whatever the tick grouping or the topics matched; the published covariances
against the errors from the truth; resets, poses, the Sun and the world frame."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2
import yaml

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.environment.magnetic_field import field_world_vector
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.msgs.decoders import parse_stamped
from rigid_body_attitude.msgs.types import (
    FIXED_LAYOUTS, IMU, MAGNETIC_FIELD, POSE_WITH_COVARIANCE_STAMPED)
from rigid_body_attitude.session.parameters import defaults
from rigid_body_attitude.session.sensors import (
    SensorSampler, mount_transforms, simulated_sensors)
from rigid_body_attitude.session.settings import load_node_scene
from rigid_body_attitude.session.uncertainty import UNKNOWN_POSITION_VARIANCE

from conftest import MS

START_NS = 1_700_000_000 * 10**9
FIELD = dict(intensity=5e-5, inclination=1.1, declination=0.2)
MAGNETOMETER = dict(rate=100.0, noise_density=2e-8, frame_id='mag_link',
                    mount_rpy=[0.2, -0.1, 1.3], seed=3, **FIELD)
STAR_TRACKER = dict(rate=50.0, frame_id='st_link', boresight=[1.0, 2.0, -0.5], seed=4,
                    cross_boresight_noise=2e-4, about_boresight_noise=2e-3)
IMU_SECTION = dict(rate=200.0, frame_id='imu_link', seed=5)
TYPES = {'imu': IMU, 'imu/mag': MAGNETIC_FIELD, 'star_tracker': POSE_WITH_COVARIANCE_STAMPED}


def scene_file(tmp_path, sensors, sun=None, omega=(0.3, 2.0, 0.1)):
    path = tmp_path / 'sensed.yaml'
    data = {'name': 'sensed', 'rate_source': 'dynamics', 'step': 0.001,
            'body': {'mass': 2.0, 'inertia': {'moments': [1.0, 2.0, 3.0]}},
            'initial_state': {'omega_body': list(omega)}, 'sensors': sensors}
    if sun is not None:
        data['sun'] = {'direction': sun}
    path.write_text(yaml.safe_dump(data))
    return str(path)


def all_three():
    return {'imu': IMU_SECTION, 'magnetometer': MAGNETOMETER, 'star_tracker': STAR_TRACKER}


def decoded(topic, data):
    """(stamp_ns, frame_id, body floats) of one sample."""
    parsed = parse_stamped(data, TYPES[topic], FIXED_LAYOUTS[TYPES[topic]].count)
    return parsed.sec * 10**9 + parsed.nanosec, parsed.frame_id, parsed.body


def by_topic(sink):
    samples = {}
    for topic, data in sink.simulated:
        samples.setdefault(topic, []).append(decoded(topic, data))
    return samples


def run(session, ticks_ns):
    for now in ticks_ns:
        session.tick(now)


def test_each_sensor_samples_every_multiple_of_its_own_period(open_scene, tmp_path):
    session, sink = open_scene(scene_file(tmp_path, all_three()))
    jitter = np.random.default_rng(1).integers(0, 15 * MS, size=60)
    ticks = [START_NS + 3 * MS + k * 20 * MS + int(j) for k, j in enumerate(jitter)]
    run(session, ticks)
    samples = by_topic(sink)
    assert set(samples) == {'imu', 'imu/mag', 'star_tracker'}
    for topic, period, frame in (('imu', 5 * MS, 'imu_link'), ('imu/mag', 10 * MS, 'mag_link'),
                                 ('star_tracker', 20 * MS, 'world')):
        stamps = [stamp for stamp, _, _ in samples[topic]]
        assert np.all(np.diff(stamps) == period), topic
        assert {frame_id for _, frame_id, _ in samples[topic]} == {frame}
        first = -(-ticks[0] // period) * period  # the first instant from the start
        # the IMU's first instant is its baseline; the point samples start there
        assert stamps[0] == first + (period if topic == 'imu' else 0), topic
        assert ticks[-1] - period < stamps[-1] <= ticks[-1], topic
    # the stops are the union of the instants: messages come in instant order
    stamps = [decoded(topic, data)[0] for topic, data in sink.simulated]
    assert stamps == sorted(stamps)


def test_the_messages_carry_the_published_covariances(open_scene, tmp_path):
    session, sink = open_scene(scene_file(tmp_path, all_three()))
    run(session, [START_NS, START_NS + 40 * MS])
    samples = by_topic(sink)
    _, _, mag = samples['imu/mag'][0]
    variance = 2e-8 ** 2 * 100.0
    assert mag[3:] == pytest.approx((variance, 0, 0, 0, variance, 0, 0, 0, variance),
                                    rel=1e-12, abs=0.0)
    _, _, pose = samples['star_tracker'][0]
    assert pose[:3] == (0.0, 0.0, 0.0)
    covariance = np.reshape(pose[7:], (6, 6))
    assert np.array_equal(covariance[:3, :3], np.eye(3) * UNKNOWN_POSITION_VARIANCE)
    assert not covariance[:3, 3:].any() and not covariance[3:, :3].any()
    eigenvalues = np.linalg.eigvalsh(covariance[3:, 3:])
    assert eigenvalues == pytest.approx([4e-8, 4e-8, 4e-6], rel=1e-9)


def test_tick_grouping_does_not_change_a_sample(open_scene, tmp_path):
    path = scene_file(tmp_path, all_three())
    first, first_sink = open_scene(path)
    second, second_sink = open_scene(path)
    third, third_sink = open_scene(path)
    run(first, [START_NS + k * 10 * MS for k in range(101)])
    run(second, [START_NS + k * 25 * MS for k in range(41)])
    run(third, [START_NS + k * 100 * MS for k in range(11)])
    counts = {topic: len(samples) for topic, samples in by_topic(first_sink).items()}
    assert counts == {'imu': 200, 'imu/mag': 101, 'star_tracker': 51}
    assert first_sink.simulated == second_sink.simulated == third_sink.simulated


class Choosy:
    """Wants samples on ``wanted`` topics only (a subscription matched to some)."""

    def __init__(self, sink, wanted):
        self.sink, self.wanted = sink, wanted

    def sensor_wanted(self, topic):
        return topic in self.wanted

    def __getattr__(self, name):
        return getattr(self.sink, name)


def test_a_sample_nobody_wants_is_not_encoded_and_changes_no_other(open_scene, tmp_path):
    path = scene_file(tmp_path, all_three())
    session, sink = open_scene(path)
    run(session, [START_NS + k * 10 * MS for k in range(51)])
    choosy, choosy_sink = open_scene(path)
    for sensor in choosy.sensors.sensors:
        sensor.sink = Choosy(choosy_sink, {'star_tracker'})
    run(choosy, [START_NS + k * 10 * MS for k in range(26)])
    for sensor in choosy.sensors.sensors:
        sensor.sink = Choosy(choosy_sink, {'imu', 'imu/mag', 'star_tracker'})
    run(choosy, [START_NS + k * 10 * MS for k in range(26, 51)])
    half = START_NS + 250 * MS
    later = [(topic, data) for topic, data in sink.simulated
             if topic == 'star_tracker' or decoded(topic, data)[0] > half]
    assert choosy_sink.simulated == later


def magnetometer_truth(attitude):
    world = np.array(field_world_vector(FIELD['intensity'], FIELD['inclination'],
                                        FIELD['declination']))
    mount = quaternion.from_rpy(MAGNETOMETER['mount_rpy'])
    return quaternion.rotate_inverse(mount, quaternion.rotate_inverse(attitude, world))


def interval_999(dof):
    return chi2.ppf(0.0005, dof), chi2.ppf(0.9995, dof)


def test_the_errors_against_the_truth_match_the_published_covariances(open_scene, tmp_path):
    """20 s of a tumbling body, a tick at every 10 ms (the truth at every sample instant):
    the sums of ``eᵀ P⁻¹ e`` lie in the 99.9 % interval of ``χ²(3N)``; the star tracker's
    covariance taken about body axes instead of world axes does not."""
    session, sink = open_scene(scene_file(tmp_path, all_three()))
    run(session, [START_NS + k * 10 * MS for k in range(2001)])
    truth = {sec * 10**9 + nanosec: np.array(sample.attitude)
             for sec, nanosec, sample, _ in sink.ticks}
    samples = by_topic(sink)
    nees = 0.0
    for stamp, _, body in samples['imu/mag']:
        error = np.array(body[:3]) - magnetometer_truth(truth[stamp])
        nees += error @ np.linalg.solve(np.reshape(body[3:], (3, 3)), error)
    count = len(samples['imu/mag'])
    assert count == 2001
    low, high = interval_999(3 * count)
    print(f'magnetometer: NEES sum {nees:.0f} over {count} samples, 99.9 % [{low:.0f}, '
          f'{high:.0f}]')
    assert low < nees < high, (low, nees, high)
    nees = body_nees = 0.0
    for stamp, _, body in samples['star_tracker']:
        measured = np.array([body[6], body[3], body[4], body[5]])  # (x, y, z, w) on the wire
        error = quaternion.log(quaternion.multiply(truth[stamp], quaternion.conjugate(measured)))
        covariance = np.reshape(body[7:], (6, 6))[3:, 3:]
        nees += error @ np.linalg.solve(covariance, error)
        turn = quaternion.to_matrix(measured)
        body_nees += error @ np.linalg.solve(turn.T @ covariance @ turn, error)
    count = len(samples['star_tracker'])
    assert count == 1001
    low, high = interval_999(3 * count)
    print(f'star tracker: NEES sum {nees:.0f} over {count} samples (about body axes '
          f'{body_nees:.0f}), 99.9 % [{low:.0f}, {high:.0f}]')
    assert low < nees < high, (low, nees, high)
    assert not low < body_nees < high, (low, body_nees, high)


def test_a_reset_starts_every_sensor_again_from_its_seed(open_scene, tmp_path):
    session, sink = open_scene(scene_file(tmp_path, all_three(), omega=(0.0, 0.0, 0.0)))
    run(session, [START_NS + k * 20 * MS for k in range(11)])
    before = [(topic, decoded(topic, data)[2]) for topic, data in sink.simulated]
    session.reset()
    sink.simulated.clear()
    run(session, [START_NS + (11 + k) * 20 * MS for k in range(11)])
    after = [(topic, decoded(topic, data)[2]) for topic, data in sink.simulated]
    # a body at rest: the same constants, noise and state, 0.22 s later
    assert after == before and len(after) == 40 + 21 + 11


def test_set_pose_samples_no_instant_twice(open_scene, tmp_path):
    session, sink = open_scene(scene_file(tmp_path, all_three(), omega=(0.0, 0.0, 0.5)))
    run(session, [START_NS, START_NS + 60 * MS])
    session.set_pose('world', (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    run(session, [START_NS + 100 * MS])
    samples = by_topic(sink)
    mag = [stamp for stamp, _, _ in samples['imu/mag']]
    assert mag == [START_NS + k * 10 * MS for k in range(11)]
    tracker = [stamp for stamp, _, _ in samples['star_tracker']]
    assert tracker == [START_NS + k * 20 * MS for k in range(6)]
    # the IMU: the pose's instant is a baseline again (nothing sent), then on
    imu = [stamp for stamp, _, _ in samples['imu']]
    assert imu == [START_NS + k * 5 * MS for k in range(1, 21)]


def test_the_sun_near_the_boresight_leaves_gaps_and_the_rest_unchanged(open_scene, tmp_path):
    """A body spinning about z with the boresight along body x: the Sun along world x is
    within the exclusion angle once per turn. A sample is missing exactly when the true
    boresight is within the angle of the Sun, and the others are those of the same sensor
    without exclusion."""
    tracker = dict(rate=50.0, boresight=[1.0, 0.0, 0.0], seed=2, sun_exclusion_angle=0.5)
    ticks = [START_NS + k * 20 * MS for k in range(201)]
    excluded, excluded_sink = open_scene(scene_file(
        tmp_path, {'star_tracker': tracker}, sun=[1.0, 0.0, 0.0], omega=(0.0, 0.0, 2.0)))
    run(excluded, ticks)
    clear, clear_sink = open_scene(scene_file(
        tmp_path, {'star_tracker': dict(tracker, sun_exclusion_angle=0.0)},
        omega=(0.0, 0.0, 2.0)))
    run(clear, ticks)
    truth = {sec * 10**9 + nanosec: sample.attitude
             for sec, nanosec, sample, _ in clear_sink.ticks}
    kept = set(excluded_sink.simulated)
    assert kept < set(clear_sink.simulated)
    for topic, data in clear_sink.simulated:
        stamp = decoded(topic, data)[0]
        boresight = quaternion.rotate_floats(truth[stamp], (1.0, 0.0, 0.0))
        assert abs(boresight[0] - math.cos(0.5)) > 1e-9  # no instant on the edge
        assert ((topic, data) in kept) == (boresight[0] <= math.cos(0.5)), stamp
    gap = len(clear_sink.simulated) - len(kept)
    assert gap == excluded.sensors.sensors[0].excluded > 0


def test_the_star_tracker_follows_the_world_frame_parameter(open_scene, tmp_path):
    session, sink = open_scene(scene_file(tmp_path, {'star_tracker': STAR_TRACKER}),
                               world_frame='map')
    run(session, [START_NS, START_NS + 20 * MS])
    session.apply(defaults() | {'world_frame': 'odom'})
    run(session, [START_NS + 40 * MS])
    assert [decoded('star_tracker', d)[1] for _, d in sink.simulated] == ['map', 'map', 'odom']


def test_the_magnetometer_reads_a_field_model_at_scene_time(open_scene, tmp_path):
    """A field model given to the magnetometer (as a scene's field model is), a field
    turning about world z at 0.5 rad/s: each sample is the field at its instant's scene time
    (seconds since the first tick), within 6 σ of the noise."""
    session, sink = open_scene(scene_file(tmp_path, {'magnetometer': dict(
        MAGNETOMETER, mount_rpy=[0.0, 0.0, 0.0])}, omega=(0.0, 0.0, 0.0)))

    class Turning:
        def field_world(self, t):
            return (4e-5 * math.cos(0.5 * t), 4e-5 * math.sin(0.5 * t), -3e-5)

    sampler = SensorSampler(simulated_sensors(session.scene, session.propagator, sink,
                                              Turning()), session.propagator, session.time_base)
    session.sensors, session.clock.advance = sampler, sampler.advance_to
    first_ns = START_NS + 123 * MS
    run(session, [first_ns + k * 100 * MS for k in range(21)])
    samples = by_topic(sink)['imu/mag']
    assert len(samples) == 200
    for stamp, _, body in samples:
        expected = Turning().field_world((stamp - first_ns) * 1e-9)
        assert np.max(np.abs(np.array(body[:3]) - expected)) < 6 * 2e-7


def test_the_mounts_are_one_transform_per_frame_off_the_body():
    scene = scene_from_mapping({
        'rate_source': 'dynamics', 'step': 0.001,
        'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'sensors': {'imu': {'rate': 200.0, 'frame_id': 'imu_link', 'mount_rpy': [0, 0, 1.0]},
                    'magnetometer': dict(MAGNETOMETER, frame_id='imu_link',
                                         mount_rpy=[0, 0, 1.0]),
                    'star_tracker': dict(STAR_TRACKER, frame_id='base_link')}})
    transforms = mount_transforms(scene, 'base_link')
    assert [(parent, child) for parent, child, _ in transforms] == [('base_link', 'imu_link')]
    assert transforms[0][2] == pytest.approx((math.cos(0.5), 0.0, 0.0, math.sin(0.5)))
    assert [child for _, child, _ in mount_transforms(scene, 'body')] == [
        'imu_link', 'base_link']


def orbiting_scene(tmp_path, magnetometer):
    path = tmp_path / 'orbiting.yaml'
    path.write_text(yaml.safe_dump({
        'name': 'orbiting', 'rate_source': 'dynamics', 'step': 0.01,
        'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'orbit': {'altitude': 500000.0, 'inclination_deg': 97.4},
        'magnetic_field': {'model': 'tilted_dipole'},
        'sensors': {'magnetometer': magnetometer}}))
    return str(path)


def test_the_magnetometer_reads_the_scenes_field_model_along_the_orbit(open_scene, tmp_path):
    """A body at rest in inertial axes on a 500 km orbit with the tilted dipole: each sample is
    the scene's field at its instant's scene time (within 6 σ of the noise), and the field
    changes along the orbit by far more than the noise."""
    session, sink = open_scene(orbiting_scene(tmp_path, {'rate': 10.0,
                                                         'noise_density': 1e-9}))
    run(session, [START_NS + k * 500 * MS for k in range(121)])
    samples = by_topic(sink)['imu/mag']
    assert len(samples) == 601
    field = session.scene.magnetic_field
    sigma = 1e-9 * math.sqrt(10.0)
    for stamp, _, body in samples:
        expected = field.field_world((stamp - START_NS) * 1e-9)
        assert np.max(np.abs(np.array(body[:3]) - expected)) < 6 * sigma
    first, last = np.array(samples[0][2][:3]), np.array(samples[-1][2][:3])
    assert np.linalg.norm(last - first) > 1e3 * sigma


def test_the_magnetometer_takes_its_field_from_the_scene_or_its_section_not_both(tmp_path):
    with pytest.raises(SceneError, match='sensors.magnetometer.intensity gives a local field '
                                         'in a scene whose magnetic_field section'):
        load_node_scene(orbiting_scene(tmp_path, MAGNETOMETER))
    no_field = {key: value for key, value in MAGNETOMETER.items() if key not in FIELD}
    loaded = load_node_scene(orbiting_scene(tmp_path, no_field))
    assert loaded.magnetometer.intensity is None and loaded.magnetic_field is not None
    with pytest.raises(SceneError, match='sensors.magnetometer needs the local field'):
        load_node_scene(scene_file(tmp_path, {'magnetometer': no_field}))
