"""The simulated magnetometer (core/sensors/magnetometer.py): section, conventions, hard and
soft iron, statistics, seeding.

Statistical checks compare N samples with the spec at a stated confidence: a mean within
``Z σ/√N`` and a sum of squares within the two-sided 99.9 % interval of χ²(N) (Z = 3.29, the
two-sided 99.9 % normal quantile).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping
from rigid_body_attitude.core.environment.magnetic_field import field_world_vector
from rigid_body_attitude.core.errors import InputError, SceneError
from rigid_body_attitude.core.sensors import (
    ImuModel, ImuSpec, MagnetometerModel, MagnetometerSpec, magnetometer_spec)

CONFIDENCE = 0.999
Z = stats.norm.ppf(0.5 + CONFIDENCE / 2.0)
#: Berlin-like field: 50 µT, dipping 68° below the horizontal, 4° east.
FIELD = dict(intensity=5.0e-5, inclination=math.radians(68.0), declination=math.radians(4.0))
#: A symmetric soft iron (an ellipsoid fit recovers a symmetric S) and a hard iron [T].
SOFT_IRON = ((1.08, 0.05, -0.02), (0.05, 0.93, 0.04), (-0.02, 0.04, 1.01))
HARD_IRON = (2.0e-5, -1.2e-5, 0.7e-5)
#: A noise small enough to leave the conventions visible to 1e-12 T.
TINY = 1e-16


def random_attitudes(count, seed=0):
    return quaternion.normalize(np.random.default_rng(seed).normal(size=(count, 4)))


def chi2_interval(dof):
    tail = (1.0 - CONFIDENCE) / 2.0
    return stats.chi2.ppf(tail, dof), stats.chi2.ppf(1.0 - tail, dof)


def scene(sensors, sun=None, step=0.001, rate_source='dynamics', **sections):
    data = {'rate_source': rate_source, 'step': step,
            'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}}, 'sensors': sensors, **sections}
    if sun is not None:
        data['sun'] = sun
    return scene_from_mapping(data)


# -- the section ---------------------------------------------------------------------------

def test_a_full_section_is_read():
    spec = magnetometer_spec({
        'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5, 'inclination': 1.2,
        'declination': -0.1, 'world_axes': 'ned', 'frame_id': 'mag', 'topic': 'mag',
        'mount_rpy': [0, 0, 1.0], 'seed': 3, 'random_walk': 1e-9, 'hard_iron': list(HARD_IRON),
        'soft_iron': [list(row) for row in SOFT_IRON], 'range': 1e-3, 'resolution': 1.5e-7})
    assert spec.period_ns == 10_000_000 and spec.seed == 3 and spec.world_axes == 'ned'
    assert spec.soft_iron == SOFT_IRON and spec.hard_iron == HARD_IRON
    assert spec.local_field().field_world(0.0) == field_world_vector(5e-5, 1.2, -0.1, 'ned')


def test_defaults_are_an_ideal_sensor_in_its_own_frame_on_imu_tools_topic():
    spec = magnetometer_spec({'rate': 50.0, 'noise_density': 1e-8})
    assert (spec.topic, spec.frame_id, spec.hard_iron) == ('imu/mag', 'magnetometer_link',
                                                           (0.0, 0.0, 0.0))
    assert np.array_equal(spec.soft_iron, np.eye(3)) and spec.local_field() is None


@pytest.mark.parametrize('section, words', [
    ({'rate': 100.0, 'noise_density': 1e-8, 'bias': [0, 0, 0]},
     "Unknown key 'bias' in sensors.magnetometer"),
    ({'noise_density': 1e-8}, "Missing key 'rate'"),
    ({'rate': 100.0}, "Missing key 'noise_density'"),
    ({'rate': 100.0, 'noise_density': 0.0}, 'sensors.magnetometer.noise_density to be in (0,'),
    ({'rate': 100.0, 'noise_density': -1e-8}, 'noise_density'),
    ({'rate': 100.0, 'noise_density': '1e-8'}, 'noise_density'),
    ({'rate': 2e4, 'noise_density': 1e-8}, 'sensors.magnetometer.rate to be in (0, 10000]'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'intensity': 1.0}, 'intensity to be in [0, 0.01]'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5, 'inclination': 2.0},
     'inclination'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5, 'declination': math.nan},
     'declination'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5, 'world_axes': 'xyz'},
     'world_axes to be one of enu, ned, nwu'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'inclination': 1.0},
     'inclination needs sensors.magnetometer.intensity'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'hard_iron': [0, 0]}, 'hard_iron to be 3 numbers'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'hard_iron': [1, 0, 0]}, 'hard_iron to be at most'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'soft_iron': [1, 0, 0]}, 'soft_iron to be a 3x3'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'soft_iron': [[0, 1, 0], [1, 0, 0], [0, 0, 1]]},
     'soft_iron to have a positive determinant'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'soft_iron': [[1, 0, 0], [0, 1, 0], [0, 0, 1e-4]]},
     'condition number at most 1000'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'soft_iron': [[1, 0, 0], [0, 1, 0], [0, 0, 100]]},
     'soft_iron to be at most 10'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'seed': 1.5}, 'seed'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'frame_id': 'mag link'}, 'frame_id'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'range': -1.0}, 'range'),
    ({'rate': 100.0, 'noise_density': 1e-8, 'resolution': 1.0}, 'resolution'),
    ('fast', 'Expected sensors.magnetometer to be a mapping'),
])
def test_a_bad_section_is_one_error_naming_the_key(section, words):
    with pytest.raises(SceneError) as raised:
        magnetometer_spec(section)
    assert words in str(raised.value) and '\n' not in str(raised.value)


def test_the_scene_needs_the_field_a_dynamics_scene_and_a_whole_number_of_steps():
    section = {'rate': 100.0, 'noise_density': 1e-8, **FIELD}
    assert scene({'magnetometer': section}).magnetometer.intensity == 5e-5
    with pytest.raises(SceneError, match='sensors.magnetometer needs the local field'):
        scene({'magnetometer': {'rate': 100.0, 'noise_density': 1e-8}})
    with pytest.raises(SceneError, match='sensors.magnetometer.rate .* whole multiple'):
        scene({'magnetometer': {**section, 'rate': 300.0}})
    with pytest.raises(SceneError, match='dynamics scene'):
        scene({'magnetometer': section}, rate_source='gyro')


# -- conventions -----------------------------------------------------------------------------

def test_a_scene_field_model_is_the_magnetometers_field_and_excludes_a_local_one():
    orbit = {'orbit': {'altitude': 500000.0, 'inclination_deg': 97.4},
             'magnetic_field': {'model': 'tilted_dipole'}}
    bare = {'rate': 100.0, 'noise_density': 1e-8}
    assert scene({'magnetometer': bare}, **orbit).magnetometer.intensity is None
    with pytest.raises(SceneError, match='magnetometer.intensity gives a local field in a '
                                         'scene whose magnetic_field section'):
        scene({'magnetometer': {**bare, **FIELD}}, **orbit)


def test_a_known_attitude_and_mount_give_the_expected_field():
    """ENU, no declination: the field is (0, H, −Z). The body yawed +90° has its x axis
    north, so it reads (H, 0, −Z); a sensor yawed +90° in the body has its x axis along the
    body's y (west) and its y axis along the body's −x (south): it reads (0, −H, −Z)."""
    spec = MagnetometerSpec(rate=100.0, noise_density=TINY, intensity=5e-5,
                            inclination=math.radians(60.0), mount_rpy=(0.0, 0.0, math.pi / 2))
    horizontal, down = 5e-5 * 0.5, 5e-5 * math.sin(math.radians(60.0))
    yawed = tuple(quaternion.exp([0.0, 0.0, math.pi / 2]).tolist())
    measured = MagnetometerModel(spec).sample(0.0, yawed)
    assert measured == pytest.approx((0.0, -horizontal, -down), abs=1e-12)


def test_a_field_model_of_the_scene_is_sampled_at_the_instant():
    class TurningField:
        """A field turning about world z at 0.1 rad/s."""

        def field_world(self, t):
            return (4e-5 * math.cos(0.1 * t), 4e-5 * math.sin(0.1 * t), -3e-5)

    model = MagnetometerModel(MagnetometerSpec(rate=100.0, noise_density=TINY),
                              TurningField())
    identity = (1.0, 0.0, 0.0, 0.0)
    for t in (0.0, 5.0, 12.5):
        assert model.sample(t, identity) == pytest.approx(TurningField().field_world(t),
                                                          abs=1e-12)
    with pytest.raises(InputError, match='magnetic field model or sensors.magnetometer'):
        MagnetometerModel(MagnetometerSpec(rate=100.0, noise_density=TINY))


# -- hard and soft iron ------------------------------------------------------------------------

def iron_spec(**extra):
    return MagnetometerSpec(rate=100.0, **FIELD, soft_iron=SOFT_IRON, hard_iron=HARD_IRON,
                            mount_rpy=(0.3, -0.2, 1.1), **extra)


def test_corrected_inverts_the_iron_of_every_sample():
    """m = S C R(q)ᵀ B + h, so S⁻¹ (m − h) is the field in the sensor frame, of length |B|."""
    spec = iron_spec(noise_density=TINY)
    model = MagnetometerModel(spec)
    mount = spec.mount()
    field = spec.local_field().field_world(0.0)
    for q in random_attitudes(50).tolist():
        true_sensor = quaternion.rotate_inverse_floats(
            mount, quaternion.rotate_inverse_floats(q, field))
        measured = model.sample(0.0, tuple(q))
        assert spec.distorted(true_sensor) == pytest.approx(measured, abs=1e-12)
        assert spec.corrected(measured) == pytest.approx(true_sensor, abs=1e-12)
        assert np.linalg.norm(spec.corrected(measured)) == pytest.approx(5e-5, rel=1e-9)


def fit_ellipsoid(points):
    """Centre h and symmetric S of ``|S⁻¹ (m − h)| = 1`` from points alone (least squares on
    the general quadric ``mᵀ Q m + 2 uᵀ m = 1``)."""
    x, y, z = points.T
    design = np.column_stack([x * x, y * y, z * z, 2 * x * y, 2 * x * z, 2 * y * z,
                              2 * x, 2 * y, 2 * z])
    a, b, c, d, e, f, g, h, i = np.linalg.lstsq(design, np.ones(len(points)), rcond=None)[0]
    quadric = np.array([[a, d, e], [d, b, f], [e, f, c]])
    centre = -np.linalg.solve(quadric, [g, h, i])
    shape = quadric / (1.0 + centre @ quadric @ centre)  # (m − h)ᵀ shape (m − h) = 1
    values, vectors = np.linalg.eigh(np.linalg.inv(shape))  # S Sᵀ = S² for a symmetric S
    return centre, vectors @ np.diag(np.sqrt(values)) @ vectors.T


def test_an_ellipsoid_fit_of_noisy_samples_gives_back_the_hard_and_soft_iron():
    """A calibration that knows only the samples and |B| recovers h and S: the round trip of
    the convention (S confused with S⁻¹ or h taken before S would be off by the iron itself:
    up to 15 % of S, 1e-5 T of h). 4000 attitudes, σ = 0.1 µT per axis: the centre of a fit
    over directions spread on the sphere has a standard deviation of about σ √(3/N) per axis,
    and S comes back within 0.1 %."""
    spec = iron_spec(noise_density=1e-8)
    model = MagnetometerModel(spec)
    count = 4000
    samples = np.array([model.sample(0.0, tuple(q)) for q in random_attitudes(count).tolist()])
    centre, soft = fit_ellipsoid(samples / 5e-5)
    sigma = math.sqrt(spec.sample_variance())
    assert np.abs(centre * 5e-5 - HARD_IRON).max() < Z * sigma * math.sqrt(3.0 / count)
    assert np.abs(soft - SOFT_IRON).max() < 1e-3
    assert np.abs(np.linalg.inv(SOFT_IRON) - SOFT_IRON).max() > 0.1  # what a mix-up costs


# -- statistics --------------------------------------------------------------------------------

def test_white_noise_has_the_published_variance_and_no_mean_or_correlation():
    spec = iron_spec(noise_density=2e-8, seed=4)
    count = 20_000
    model = MagnetometerModel(spec)
    mount = spec.mount()
    field = spec.local_field().field_world(0.0)
    errors = []
    for q in random_attitudes(count, seed=1).tolist():
        truth = spec.distorted(quaternion.rotate_inverse_floats(
            mount, quaternion.rotate_inverse_floats(q, field)))
        errors.append(np.subtract(model.sample(0.0, tuple(q)), truth))
    errors = np.array(errors)
    variance = spec.sample_variance()
    assert variance == pytest.approx(2e-8 ** 2 * 100.0)
    assert spec.magnetic_field_covariance() == (variance, 0.0, 0.0, 0.0, variance, 0.0, 0.0,
                                                0.0, variance)
    assert np.all(np.abs(errors.mean(axis=0)) < Z * math.sqrt(variance / count))
    low, high = chi2_interval(count)
    sums = np.sum(errors ** 2, axis=0) / variance
    assert np.all((low < sums) & (sums < high)), sums
    correlation = np.corrcoef(errors.T)
    assert np.abs(correlation[np.triu_indices(3, 1)]).max() < Z / math.sqrt(count)


def test_the_bias_walks_with_steps_of_k_root_dt():
    spec = MagnetometerSpec(rate=50.0, noise_density=TINY, random_walk=3e-9, **FIELD, seed=9)
    model = MagnetometerModel(spec)
    level = (1.0, 0.0, 0.0, 0.0)
    samples = np.array([model.sample(0.0, level) for _ in range(20_001)])
    steps = np.diff(samples, axis=0)
    variance = 3e-9 ** 2 * spec.period
    low, high = chi2_interval(len(steps))
    sums = np.sum(steps ** 2, axis=0) / variance
    assert np.all((low < sums) & (sums < high)), sums
    field_sensor = field_world_vector(FIELD['intensity'], FIELD['inclination'],
                                      FIELD['declination'])
    assert np.subtract(samples[-1], field_sensor) == pytest.approx(model.bias, abs=1e-13)


def test_saturation_quantisation_and_their_variance():
    spec = MagnetometerSpec(rate=100.0, noise_density=TINY, range=3e-5, resolution=1e-6)
    model = MagnetometerModel(spec, _constant((5e-5, -1.04e-5, 0.0)))
    assert model.sample(0.0, (1.0, 0.0, 0.0, 0.0)) == pytest.approx((3e-5, -1e-5, 0.0),
                                                                    abs=1e-18)
    assert spec.sample_variance() == pytest.approx(TINY ** 2 * 100.0 + 1e-12 / 12.0)


def _constant(vector):
    class Constant:
        def field_world(self, t):
            return vector
    return Constant()


# -- seeding -----------------------------------------------------------------------------------

def test_seeded_samples_repeat_after_reset_and_do_not_depend_on_the_block_size():
    spec = iron_spec(noise_density=1e-8, random_walk=1e-9, seed=21)
    attitudes = [tuple(q) for q in random_attitudes(3000, seed=2).tolist()]
    model = MagnetometerModel(spec)
    first = [model.sample(0.01 * k, q) for k, q in enumerate(attitudes)]
    model.reset()
    assert [model.sample(0.01 * k, q) for k, q in enumerate(attitudes)] == first
    for block in (1, 7, 4096):
        other = MagnetometerModel(spec, noise_block=block)
        assert [other.sample(0.01 * k, q) for k, q in enumerate(attitudes)] == first
    assert MagnetometerModel(iron_spec(noise_density=1e-8, random_walk=1e-9, seed=22)).sample(
        0.0, attitudes[0]) != first[0]


def test_a_bias_walk_leaves_the_white_noise_as_it_was():
    quiet = MagnetometerModel(iron_spec(noise_density=1e-8, seed=5))
    walking = MagnetometerModel(iron_spec(noise_density=1e-8, random_walk=1e-9, seed=5))
    for q in random_attitudes(100, seed=3).tolist():
        difference = np.subtract(walking.sample(0.0, tuple(q)), quiet.sample(0.0, tuple(q)))
        assert difference == pytest.approx(walking.bias, abs=1e-18)


def test_the_stream_is_not_the_imus_of_the_same_seed():
    """Seed 0 for both sensors: the IMU's first normals and the magnetometer's differ (equal
    streams would give equal unit normals, i.e. correlated noise across sensors)."""
    imu = ImuModel(ImuSpec(rate=100.0, seed=0, gyroscope_turn_on_bias=0.0,
                           gyroscope_random_walk=0.0, gyroscope_scale_stddev=0.0,
                           gyroscope_misalignment_stddev=0.0, gyroscope_noise_density=1.0))
    magnetometer = MagnetometerModel(MagnetometerSpec(rate=100.0, noise_density=1e-3),
                                     _constant((0.0, 0.0, 0.0)))
    gyro = np.array([imu.measure((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))[0] for _ in range(2000)])
    field = np.array([magnetometer.measure((0.0, 0.0, 0.0)) for _ in range(2000)])
    correlation = np.corrcoef(gyro[:, 0], field[:, 0])[0, 1]
    assert abs(correlation) < Z / math.sqrt(2000)
