"""The simulated star tracker (core/sensors/star_tracker.py): section, frames and the error
convention, the covariance about world axes, Sun exclusion, seeding.

Statistical checks compare N samples with the spec at a stated confidence: a mean within
``Z σ/√N`` and a sum of squares within the two-sided 99.9 % interval of χ²(dof) (Z = 3.29).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.environment.sun import ConstantSunDirection
from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.sensors import StarTrackerModel, StarTrackerSpec, star_tracker_spec
from rigid_body_attitude.core.sensors.star_tracker import ARCSECOND

CONFIDENCE = 0.999
Z = stats.norm.ppf(0.5 + CONFIDENCE / 2.0)
ACROSS, ABOUT = 5.0 * ARCSECOND, 35.0 * ARCSECOND
#: A noise small enough to leave the conventions visible to 1e-10 rad.
TINY = 1e-13
IDENTITY = (1.0, 0.0, 0.0, 0.0)


def random_attitudes(count, seed=0):
    return quaternion.normalize(np.random.default_rng(seed).normal(size=(count, 4)))


def chi2_interval(dof):
    tail = (1.0 - CONFIDENCE) / 2.0
    return stats.chi2.ppf(tail, dof), stats.chi2.ppf(1.0 - tail, dof)


def scene(sensors, sun=None, step=0.001):
    data = {'rate_source': 'dynamics', 'step': step,
            'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}}, 'sensors': sensors}
    if sun is not None:
        data['sun'] = sun
    return scene_from_mapping(data)


def body_error(true, measured):
    """δθ_body with ``measured = true ⊗ exp(δθ_body)``."""
    return quaternion.log(quaternion.multiply(quaternion.conjugate(true), measured))


def world_error(true, measured):
    """δθ_world with ``true = exp(δθ_world) ⊗ measured`` (the published convention)."""
    return quaternion.log(quaternion.multiply(true, quaternion.conjugate(measured)))


# -- the section -----------------------------------------------------------------------------

def test_a_full_section_is_read_with_typical_defaults():
    spec = star_tracker_spec({'rate': 4.0, 'frame_id': 'st', 'topic': 'st/pose', 'seed': 7,
                              'boresight': [0, 0, -2], 'cross_boresight_noise': 1e-5,
                              'about_boresight_noise': 1e-4, 'misalignment_stddev': 1e-4,
                              'sun_exclusion_angle': 0.6})
    assert spec.period_ns == 250_000_000 and spec.boresight == (0.0, 0.0, -1.0)
    default = star_tracker_spec({'rate': 10.0})
    assert (default.topic, default.frame_id) == ('star_tracker', 'star_tracker_link')
    assert default.cross_boresight_noise == pytest.approx(ACROSS)
    assert default.about_boresight_noise == pytest.approx(ABOUT)
    assert default.sun_exclusion_angle == 0.0 and default.misalignment_stddev == 0.0


@pytest.mark.parametrize('section, words', [
    ({'rate': 10.0, 'fov': 0.3}, "Unknown key 'fov' in sensors.star_tracker"),
    ({'seed': 1}, "Missing key 'rate'"),
    ({'rate': 2000.0}, 'sensors.star_tracker.rate to be in (0, 1000]'),
    ({'rate': 10.0, 'cross_boresight_noise': 0.0}, 'cross_boresight_noise to be in (0, 0.1]'),
    ({'rate': 10.0, 'about_boresight_noise': 1.0}, 'about_boresight_noise to be in (0, 0.1]'),
    ({'rate': 10.0, 'misalignment_stddev': -1e-4}, 'misalignment_stddev'),
    ({'rate': 10.0, 'sun_exclusion_angle': 4.0}, 'sun_exclusion_angle to be in [0, 3.14159]'),
    ({'rate': 10.0, 'mount_rpy': [0, 0, 0], 'boresight': [1, 0, 0]}, 'not both'),
    ({'rate': 10.0, 'boresight': [0, 0, 0]}, 'boresight to be a non-zero direction'),
    ({'rate': 10.0, 'boresight': [1, 0]}, 'boresight to be 3 numbers'),
    ({'rate': 10.0, 'boresight': [1, 0, math.inf]}, 'boresight'),
    ({'rate': 10.0, 'mount_rpy': [0, 0, 20]}, 'mount_rpy'),
    ({'rate': 10.0, 'seed': 2**63}, 'seed'),
    ({'rate': 10.0, 'frame_id': ''}, 'frame_id'),
    ([10.0], 'Expected sensors.star_tracker to be a mapping'),
])
def test_a_bad_section_is_one_error_naming_the_key(section, words):
    with pytest.raises(SceneError) as raised:
        star_tracker_spec(section)
    assert words in str(raised.value) and '\n' not in str(raised.value)


def test_the_exclusion_angle_needs_a_sun_in_the_scene():
    section = {'rate': 10.0, 'sun_exclusion_angle': 0.5}
    with pytest.raises(SceneError, match="sun_exclusion_angle needs the Sun's direction"):
        scene({'star_tracker': section})
    assert scene({'star_tracker': section}, sun={'direction': [0, 2, 0]}).sun.direction == (
        0.0, 1.0, 0.0)
    assert scene({'star_tracker': {'rate': 10.0}}).star_tracker.rate == 10.0
    with pytest.raises(SceneError, match='sensors.star_tracker.rate .* whole multiple'):
        scene({'star_tracker': {'rate': 3.0}}, step=0.002)
    with pytest.raises(InputError, match='Sun direction'):
        StarTrackerModel(StarTrackerSpec(rate=10.0, sun_exclusion_angle=0.5))


# -- frames and the error convention ------------------------------------------------------------

@pytest.mark.parametrize('given, boresight', [
    ({'mount_rpy': (0.0, math.pi / 2, 0.0)}, (1.0, 0.0, 0.0)),
    ({'mount_rpy': (-math.pi / 2, 0.0, 0.0)}, (0.0, 1.0, 0.0)),
    ({'boresight': (1.0, 0.0, 0.0)}, (1.0, 0.0, 0.0)),
    ({'boresight': (0.0, 0.0, -1.0)}, (0.0, 0.0, -1.0)),
    ({'boresight': (0.6, 0.0, -0.8)}, (0.6, 0.0, -0.8)),
])
def test_the_boresight_is_the_sensor_z_axis_in_the_body(given, boresight):
    spec = StarTrackerSpec(rate=10.0, **given)
    assert spec.boresight_body() == pytest.approx(boresight, abs=1e-15)
    boresight_by_mount = quaternion.rotate(spec.mount(), [0.0, 0.0, 1.0])
    assert boresight_by_mount == pytest.approx(boresight, abs=1e-15)


def test_a_known_attitude_is_measured_as_itself():
    model = StarTrackerModel(StarTrackerSpec(rate=10.0, cross_boresight_noise=TINY,
                                             about_boresight_noise=TINY, mount_rpy=(1, 2, 3)))
    for q in random_attitudes(20).tolist():
        assert quaternion.attitude_error(q, model.measure(tuple(q))) < 1e-12


def test_the_noise_about_the_boresight_turns_the_body_about_the_boresight():
    """Boresight along body x; noise about it only: every measured attitude differs from the
    true one by a rotation about body x, on the right (q_meas = q ⊗ exp(δθ_body)), which in
    world axes is a rotation about the boresight in the world, R(q) b."""
    spec = StarTrackerSpec(rate=10.0, boresight=(1.0, 0.0, 0.0), cross_boresight_noise=TINY,
                           about_boresight_noise=1e-3)
    model = StarTrackerModel(spec)
    for q in random_attitudes(50, seed=1):
        measured = model.measure(tuple(q.tolist()))
        in_body = body_error(q, measured)
        assert np.linalg.norm(in_body) > 1e-6
        assert np.abs(in_body[1:]).max() < 1e-11
        in_world = world_error(q, measured)
        boresight_world = quaternion.rotate(q, [1.0, 0.0, 0.0])
        assert np.linalg.norm(np.cross(in_world, boresight_world)) < 1e-12


def test_the_misalignment_is_the_same_rotation_in_every_sample():
    spec = StarTrackerSpec(rate=10.0, mount_rpy=(0.2, -0.4, 1.0), cross_boresight_noise=TINY,
                           about_boresight_noise=TINY, misalignment_stddev=1e-3, seed=5)
    model = StarTrackerModel(spec)
    expected = quaternion.rotate(spec.mount(), model.misalignment)
    assert np.linalg.norm(model.misalignment) > 1e-4
    for q in random_attitudes(20, seed=2):
        error = body_error(q, model.measure(tuple(q.tolist())))
        assert error == pytest.approx(expected, abs=1e-12)


# -- the covariance ----------------------------------------------------------------------------

def test_the_covariance_is_the_sensor_noise_turned_into_world_axes():
    spec = StarTrackerSpec(rate=10.0, mount_rpy=(0.3, 1.1, -0.7))
    mount = quaternion.to_matrix(spec.mount())
    sensor = np.diag(spec.sensor_variances())
    for q in random_attitudes(10, seed=3):
        rotation = quaternion.to_matrix(q)
        expected = rotation @ mount @ sensor @ mount.T @ rotation.T
        covariance = np.array(spec.orientation_covariance(tuple(q.tolist()))).reshape(3, 3)
        assert covariance == pytest.approx(expected, abs=1e-22)
        values, vectors = np.linalg.eigh(covariance)
        assert values == pytest.approx([ACROSS ** 2, ACROSS ** 2, ABOUT ** 2], rel=1e-9)
        boresight = rotation @ spec.boresight_body()
        assert abs(vectors[:, 2] @ boresight) == pytest.approx(1.0, abs=1e-12)


@pytest.fixture(scope='module')
def errors_of_many_samples():
    """20 000 samples of a star tracker mounted off every body axis, at random attitudes:
    errors about world axes and about the sensor's axes, and the published covariances."""
    spec = StarTrackerSpec(rate=10.0, mount_rpy=(0.3, 1.1, -0.7), seed=11)
    model = StarTrackerModel(spec)
    truth = random_attitudes(20_000, seed=4)
    measured = np.array([model.measure(q) for q in map(tuple, truth.tolist())])
    covariances = np.array([spec.orientation_covariance(q) for q in map(tuple, measured.tolist())
                            ]).reshape(-1, 3, 3)
    in_sensor = quaternion.rotate_inverse(spec.mount(), body_error(truth, measured))
    return spec, truth, world_error(truth, measured), in_sensor, covariances


def test_the_noise_has_the_spec_variances_about_the_sensor_axes(errors_of_many_samples):
    spec, _, _, in_sensor, _ = errors_of_many_samples
    count = len(in_sensor)
    variances = np.array(spec.sensor_variances())
    assert np.all(np.abs(in_sensor.mean(axis=0)) < Z * np.sqrt(variances / count))
    low, high = chi2_interval(count)
    sums = np.sum(in_sensor ** 2, axis=0) / variances
    assert np.all((low < sums) & (sums < high)), sums


def test_the_published_covariance_is_consistent_about_world_axes(errors_of_many_samples):
    """NEES of the world-axis error against the published covariance: the sum over N samples
    is χ²(3N). The covariance taken about the body's axes (M Σ Mᵀ, without R) fails it."""
    spec, truth, in_world, _, covariances = errors_of_many_samples
    low, high = chi2_interval(3 * len(in_world))
    nees = np.einsum('ni,nij,nj->', in_world, np.linalg.inv(covariances), in_world)
    assert low < nees < high
    mount = quaternion.to_matrix(spec.mount())
    body_axes = mount @ np.diag(spec.sensor_variances()) @ mount.T
    wrong = np.einsum('ni,ij,nj->', in_world, np.linalg.inv(body_axes), in_world)
    assert not low < wrong < high
    assert truth.shape == in_world.shape[:1] + (4,)


# -- Sun exclusion -----------------------------------------------------------------------------

def pointing(angle):
    """The body attitude whose boresight (body x) is ``angle`` from the Sun (world x), turned
    about world z."""
    return tuple(quaternion.exp([0.0, 0.0, angle]).tolist())


def test_no_sample_within_the_exclusion_angle_of_the_sun():
    spec = StarTrackerSpec(rate=10.0, boresight=(1.0, 0.0, 0.0), sun_exclusion_angle=0.5)
    model = StarTrackerModel(spec, ConstantSunDirection((2.0, 0.0, 0.0)))
    assert model.sample(0.0, pointing(0.0)) is None
    assert model.sample(0.0, pointing(0.5 - 1e-9)) is None
    assert model.sample(0.0, pointing(-0.5 + 1e-9)) is None
    assert model.sample(0.0, pointing(0.5 + 1e-9)) is not None
    assert model.sample(0.0, pointing(math.pi)) is not None
    assert not StarTrackerModel(StarTrackerSpec(rate=10.0, boresight=(1.0, 0.0, 0.0)),
                                ConstantSunDirection((1.0, 0.0, 0.0))).excluded(0.0, IDENTITY)


def test_an_excluded_instant_draws_its_noise_all_the_same():
    """The samples after an exclusion are those of the same sensor with no Sun at all."""
    attitudes = [pointing(angle) for angle in np.linspace(-1.0, 1.0, 41)]
    blinded = StarTrackerModel(StarTrackerSpec(rate=10.0, boresight=(1.0, 0.0, 0.0), seed=3,
                                               sun_exclusion_angle=0.325),
                               ConstantSunDirection((1.0, 0.0, 0.0)))
    free = StarTrackerModel(StarTrackerSpec(rate=10.0, boresight=(1.0, 0.0, 0.0), seed=3))
    results = [(blinded.sample(0.0, q), free.sample(0.0, q)) for q in attitudes]
    assert sum(a is None for a, _ in results) == 13  # |angle| < 0.325: -0.3 ... 0.3
    assert all(a == b for a, b in results if a is not None)


# -- seeding -----------------------------------------------------------------------------------

def test_seeded_samples_repeat_after_reset_and_do_not_depend_on_the_block_size():
    spec = StarTrackerSpec(rate=10.0, seed=17, misalignment_stddev=1e-4)
    attitudes = list(map(tuple, random_attitudes(2500, seed=6).tolist()))
    model = StarTrackerModel(spec)
    misalignment = model.misalignment
    first = [model.sample(0.0, q) for q in attitudes]
    model.reset()
    assert model.misalignment == misalignment
    assert [model.sample(0.0, q) for q in attitudes] == first
    for block in (1, 5, 3000):
        other = StarTrackerModel(spec, noise_block=block)
        assert [other.sample(0.0, q) for q in attitudes] == first
    other_seed = StarTrackerModel(StarTrackerSpec(rate=10.0, seed=18, misalignment_stddev=1e-4))
    assert other_seed.misalignment != misalignment


def test_the_misalignment_draw_leaves_the_noise_as_it_was():
    aligned = StarTrackerModel(StarTrackerSpec(rate=10.0, seed=2))
    misaligned = StarTrackerModel(StarTrackerSpec(rate=10.0, seed=2, misalignment_stddev=1e-3))
    q = IDENTITY
    for _ in range(20):
        a, b = aligned.measure(q), misaligned.measure(q)
        expected = quaternion.multiply(quaternion.exp(misaligned.misalignment), a)
        assert b == pytest.approx(quaternion.continuous(expected, b).tolist(), abs=1e-15)
