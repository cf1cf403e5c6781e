"""Tests of the quaternion algebra and of the conventions stated in quaternion.py.

Tolerances: one float64 operation rounds to 2⁻⁵³ ≈ 1.1e−16 relative; the functions here chain a
few such operations, so results that are exact in real arithmetic are checked to a few 1e−16
(absolute for unit quantities). Series branches are checked against mpmath at 50 digits.
"""

import math
import re

import mpmath
import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.attitude.kinematics import quaternion_rate

mpmath.mp.dps = 50

UNIT = {'1': (1.0, 0.0, 0.0, 0.0), 'i': (0.0, 1.0, 0.0, 0.0), 'j': (0.0, 0.0, 1.0, 0.0),
        'k': (0.0, 0.0, 0.0, 1.0)}
E_X, E_Y, E_Z = np.eye(3)
ROUND_OFF = 4e-16  # a few units of round-off for unit-size results of a few operations


def random_quaternions(count, seed=1):
    """Unit quaternions uniformly distributed on S³."""
    return quat.normalize(np.random.default_rng(seed).normal(size=(count, 4)))


def negate(q):
    return -np.asarray(q)


# --- Hamilton product -------------------------------------------------------------------------

@pytest.mark.parametrize('left, right, product', [
    ('i', 'j', 'k'), ('j', 'k', 'i'), ('k', 'i', 'j'),
    ('j', 'i', '-k'), ('k', 'j', '-i'), ('i', 'k', '-j'),
    ('i', 'i', '-1'), ('j', 'j', '-1'), ('k', 'k', '-1'), ('1', 'k', 'k')])
def test_multiply_hamilton_units(left, right, product):
    sign = -1.0 if product.startswith('-') else 1.0
    expected = sign * np.array(UNIT[product.lstrip('-')])
    np.testing.assert_array_equal(quat.multiply(UNIT[left], UNIT[right]), expected)


def test_multiply_ijk_is_minus_one():
    ijk = quat.multiply(quat.multiply(UNIT['i'], UNIT['j']), UNIT['k'])
    np.testing.assert_array_equal(ijk, [-1.0, 0.0, 0.0, 0.0])


def test_multiply_associative_not_commutative():
    p, q, r = random_quaternions(3)
    left = quat.multiply(quat.multiply(p, q), r)
    right = quat.multiply(p, quat.multiply(q, r))
    np.testing.assert_allclose(left, right, rtol=0, atol=ROUND_OFF * 2)
    # pq − qp = 2 (0, pv × qv): far from zero for random p, q
    commutator = quat.multiply(p, q) - quat.multiply(q, p)
    np.testing.assert_allclose(commutator[1:], 2.0 * np.cross(p[1:], q[1:]), atol=ROUND_OFF)
    assert np.linalg.norm(commutator) > 0.1


def test_multiply_formula_and_norm():
    p, q = random_quaternions(2, seed=7)
    scalar = p[0] * q[0] - p[1:] @ q[1:]
    vector = p[0] * q[1:] + q[0] * p[1:] + np.cross(p[1:], q[1:])
    np.testing.assert_allclose(quat.multiply(p, q), np.r_[scalar, vector], atol=ROUND_OFF)
    scaled = quat.multiply(3.0 * p, 0.5 * q)
    assert np.linalg.norm(scaled) == pytest.approx(1.5, rel=ROUND_OFF)


def test_conjugate_is_inverse():
    q = random_quaternions(1)[0]
    np.testing.assert_array_equal(quat.conjugate(q), q * [1, -1, -1, -1])
    np.testing.assert_allclose(quat.multiply(q, quat.conjugate(q)), quat.identity(),
                               atol=ROUND_OFF)
    np.testing.assert_allclose(quat.multiply(quat.conjugate(q), q), quat.identity(),
                               atol=ROUND_OFF)


def test_normalize_and_norm_error():
    q = np.array([[3.0, 0.0, 4.0, 0.0], [0.0, 0.0, 0.0, 2.0]])
    np.testing.assert_array_equal(quat.normalize(q), [[0.6, 0.0, 0.8, 0.0], [0, 0, 0, 1.0]])
    assert quat.norm_error([1.0, 0.0, 0.0, 1e-4]) == pytest.approx(5e-9, rel=1e-7)
    np.testing.assert_array_equal(quat.norm_error(q), [4.0, 1.0])


def test_normalize_zero_rejected():
    with pytest.raises(InputError, match=re.escape('Expected `q` to be non-zero to normalise')):
        quat.normalize([0.0, 0.0, 0.0, 0.0])


def test_identity_shape():
    np.testing.assert_array_equal(quat.identity((2,)), [[1, 0, 0, 0], [1, 0, 0, 0]])


# --- exp / log, series branch against mpmath ------------------------------------------------

def exact_exp(rotation_vector):
    """exp of the float rotation vector, evaluated at 50 digits."""
    v = [mpmath.mpf(float(c)) for c in rotation_vector]
    angle = mpmath.sqrt(sum(c * c for c in v))
    if angle == 0:
        return [mpmath.mpf(1), mpmath.mpf(0), mpmath.mpf(0), mpmath.mpf(0)]
    scale = mpmath.sin(angle / 2) / angle
    return [mpmath.cos(angle / 2)] + [scale * c for c in v]


def exact_log(q):
    """log of the float quaternion q (w > 0), evaluated at 50 digits."""
    w = mpmath.mpf(float(q[0]))
    v = [mpmath.mpf(float(c)) for c in q[1:]]
    s = mpmath.sqrt(sum(c * c for c in v))
    scale = 2 / w if s == 0 else 2 * mpmath.atan2(s, w) / s  # lim_{s→0} 2 atan2(s, w)/s = 2/w
    return [scale * c for c in v]


def relative_errors(computed, exact):
    return [float(abs(mpmath.mpf(float(c)) - e) / abs(e)) if e != 0 else float(abs(c))
            for c, e in zip(computed, exact)]


SERIES_ANGLES = [
    0.0, 1e-12, 1e-5,
    np.nextafter(quat.SERIES_THRESHOLD, 0.0),   # last angle of the series branch
    quat.SERIES_THRESHOLD,                      # first angle of the sin/atan2 branch
    np.nextafter(quat.SERIES_THRESHOLD, 1.0),
    1e-3, 0.5, 2.0]


@pytest.mark.parametrize('angle', SERIES_ANGLES)
@pytest.mark.parametrize('direction', [(1.0, 0.0, 0.0), (0.6, -0.48, 0.64)])
def test_exp_log_match_mpmath(angle, direction):
    # 50-digit reference from the same float input: the only error is the float64 evaluation,
    # a few roundings (series: ½ − a²/48 + a⁴/3840 truncates at a⁶/645120 < 1e−30 relative).
    rotation_vector = angle * np.array(direction)
    q = quat.exp(rotation_vector)
    assert max(relative_errors(q, exact_exp(rotation_vector))) <= 3e-16
    log_q = quat.log(q)
    assert max(relative_errors(log_q, exact_log(q))) <= 3e-16
    np.testing.assert_allclose(log_q, rotation_vector, rtol=4e-16, atol=0)


def test_exp_log_subnormal_exact_to_one_subnormal_ulp():
    # 5e−320 is subnormal: it carries only ~14 bits, so 'exact' means within one subnormal
    # spacing (2⁻¹⁰⁷⁴ ≈ 4.9e−324) of the 50-digit value; nothing divides by zero.
    tiny = 5e-320
    spacing = 2.0 ** -1074
    for rotation_vector in ([tiny, 0.0, 0.0], [0.0, -tiny, tiny]):
        q = quat.exp(rotation_vector)
        assert np.all(np.isfinite(q))
        errors = [float(abs(mpmath.mpf(float(c)) - e)) for c, e in
                  zip(q, exact_exp(rotation_vector))]
        assert max(errors) <= spacing
        log_q = quat.log(q)
        assert np.all(np.isfinite(log_q))
        assert np.max(np.abs(log_q - rotation_vector)) <= spacing


def test_exp_rotation_angle_and_axis():
    q = quat.exp([0.0, 0.0, 1.0])
    np.testing.assert_allclose(q, [math.cos(0.5), 0.0, 0.0, math.sin(0.5)], atol=ROUND_OFF)
    # 2π is the identity up to sign: exp(2π e) = (−1, 0, 0, 0)
    np.testing.assert_allclose(quat.exp([2.0 * np.pi, 0, 0]), [-1, 0, 0, 0], atol=ROUND_OFF)


def test_log_inverse_of_exp_and_angle_range():
    rng = np.random.default_rng(3)
    directions = quat.normalize(rng.normal(size=(200, 4)))[:, 1:]
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    angles = rng.uniform(0.0, np.pi - 1e-3, size=(200, 1))
    rotation_vectors = angles * directions
    # log(exp(v)) = v for |v| < π; the condition grows like 1/(π − |v|) so allow 1e−13.
    np.testing.assert_allclose(quat.log(quat.exp(rotation_vectors)), rotation_vectors,
                               rtol=0, atol=1e-13)
    # beyond π log returns the equivalent rotation 2π − |v| about −axis
    v = 4.0 * E_X
    np.testing.assert_allclose(quat.log(quat.exp(v)), -(2 * np.pi - 4.0) * E_X, atol=1e-15)
    # sign invariance
    q = random_quaternions(50)
    np.testing.assert_allclose(quat.log(q), quat.log(-q), atol=0)
    assert np.all(np.linalg.norm(quat.log(q), axis=-1) <= np.pi)


def test_log_near_pi_stays_accurate():
    # atan2 keeps angles near π exact: exp(log(q)) = ±q to round-off
    q = quat.exp([0.0, np.pi - 1e-9, 0.0])
    np.testing.assert_allclose(np.linalg.norm(quat.log(q)), np.pi - 1e-9, rtol=2e-16)
    np.testing.assert_allclose(quat.exp(quat.log(q)), q, atol=ROUND_OFF)


# --- rotations and matrices -----------------------------------------------------------------

def test_rotate_matches_matrix_and_sandwich():
    q = random_quaternions(20)
    vectors = np.random.default_rng(5).normal(size=(20, 3))
    rotated = quat.rotate(q, vectors)
    by_matrix = np.einsum('nij,nj->ni', quat.to_matrix(q), vectors)
    np.testing.assert_allclose(rotated, by_matrix, atol=1e-15 * 10)
    pure = np.concatenate([np.zeros((20, 1)), vectors], axis=-1)
    sandwich = quat.multiply(quat.multiply(q, pure), quat.conjugate(q))
    np.testing.assert_allclose(sandwich[:, 1:], rotated, atol=1e-15 * 10)
    np.testing.assert_allclose(quat.rotate_inverse(q, rotated), vectors, atol=1e-15 * 10)


def test_to_matrix_is_rotation():
    matrices = quat.to_matrix(random_quaternions(100))
    identity = np.einsum('nji,njk->nik', matrices, matrices)
    np.testing.assert_allclose(identity, np.broadcast_to(np.eye(3), (100, 3, 3)), atol=1e-15)
    np.testing.assert_allclose(np.linalg.det(matrices), 1.0, atol=1e-15)


def test_matrix_round_trip_sign_invariant():
    q = random_quaternions(1000)
    # include the branches of Shepperd's method: rotations by π about each axis, identity
    q = np.concatenate([q, [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]])
    back = quat.from_matrix(quat.to_matrix(q))
    assert np.all(back[:, 0] >= 0.0)
    assert np.max(quat.attitude_error(q, back)) <= 2e-15
    np.testing.assert_allclose(back, quat.canonical(q), atol=1e-15)
    np.testing.assert_allclose(quat.from_matrix(quat.to_matrix(-q)), back, atol=0)


# --- Euler (ZXZ) and Bryant (XYZ) angles ----------------------------------------------------

def test_euler_zxz_definition():
    psi, theta, phi = 0.4, 1.1, -2.0
    expected = quat.multiply(quat.multiply(quat.exp(psi * E_Z), quat.exp(theta * E_X)),
                             quat.exp(phi * E_Z))
    np.testing.assert_allclose(quat.from_euler_zxz([psi, theta, phi]), expected, atol=ROUND_OFF)


def test_bryant_xyz_definition():
    a1, a2, a3 = -0.7, 0.3, 2.5
    expected = quat.multiply(quat.multiply(quat.exp(a1 * E_X), quat.exp(a2 * E_Y)),
                             quat.exp(a3 * E_Z))
    np.testing.assert_allclose(quat.from_bryant_xyz([a1, a2, a3]), expected, atol=ROUND_OFF)


def test_euler_zxz_round_trip_away_from_singularity():
    rng = np.random.default_rng(11)
    angles = np.stack([rng.uniform(-np.pi, np.pi, 2000), rng.uniform(0.01, np.pi - 0.01, 2000),
                       rng.uniform(-np.pi, np.pi, 2000)], axis=-1)
    # angle condition number ≤ 1/sin θ ≤ 100: 100 × a few round-offs
    np.testing.assert_allclose(quat.as_euler_zxz(quat.from_euler_zxz(angles)), angles,
                               rtol=0, atol=1e-13)


def test_bryant_xyz_round_trip_away_from_singularity():
    rng = np.random.default_rng(12)
    angles = np.stack([rng.uniform(-np.pi, np.pi, 2000),
                       rng.uniform(-np.pi / 2 + 0.01, np.pi / 2 - 0.01, 2000),
                       rng.uniform(-np.pi, np.pi, 2000)], axis=-1)
    np.testing.assert_allclose(quat.as_bryant_xyz(quat.from_bryant_xyz(angles)), angles,
                               rtol=0, atol=1e-13)


@pytest.mark.parametrize('to_angles, from_angles', [
    (quat.as_euler_zxz, quat.from_euler_zxz), (quat.as_bryant_xyz, quat.from_bryant_xyz)])
def test_angles_reproduce_any_attitude(to_angles, from_angles):
    # whatever the branch, the angles must give back the same rotation (a few round-offs)
    q = random_quaternions(20000, seed=4)
    assert np.max(quat.attitude_error(q, from_angles(to_angles(q)))) <= 4e-15


@pytest.mark.parametrize('angles', [[0.3, 1e-9, 0.5], [0.3, np.pi - 1e-9, 0.5],
                                    [-2.0, 1e-6, 1.0]])
def test_euler_zxz_near_gimbal_lock_keeps_the_rotation(angles):
    # θ = 1e−9 is a real rotation: reading θ as arccos(R₃₃) lost it entirely (error 1e−9 rad)
    q = quat.from_euler_zxz(angles)
    recovered = quat.as_euler_zxz(q)
    assert quat.attitude_error(q, quat.from_euler_zxz(recovered)) <= 1e-15
    assert recovered[1] == pytest.approx(angles[1], rel=1e-12, abs=1e-15)


@pytest.mark.parametrize('angles', [[0.3, np.pi / 2 - 1e-9, 0.5], [0.3, -np.pi / 2 + 1e-9, 0.5],
                                    [1.0, 1e-7 - np.pi / 2, -2.0]])
def test_bryant_xyz_near_gimbal_lock_keeps_the_rotation(angles):
    # via the matrix, α₁ and α₃ took independent 1e−7 errors here (rotation error 5e−8 rad)
    q = quat.from_bryant_xyz(angles)
    assert quat.attitude_error(q, quat.from_bryant_xyz(quat.as_bryant_xyz(q))) <= 1e-15


@pytest.mark.parametrize('theta', [0.0, np.pi])
def test_euler_zxz_gimbal_lock_branch(theta):
    # at sin θ = 0 only ψ ± φ is defined: φ is set to 0 and ψ carries the rotation
    q = quat.from_euler_zxz([0.3, theta, 0.5])
    psi, theta_out, phi = quat.as_euler_zxz(q)
    assert phi == 0.0
    assert theta_out == pytest.approx(theta, abs=1e-15)
    assert psi == pytest.approx(0.8 if theta == 0.0 else -0.2, abs=1e-15)
    assert quat.attitude_error(q, quat.from_euler_zxz([psi, theta_out, phi])) <= 1e-15


@pytest.mark.parametrize('alpha2', [np.pi / 2, -np.pi / 2])
def test_bryant_xyz_gimbal_lock_branch(alpha2):
    q = quat.from_bryant_xyz([0.3, alpha2, 0.5])
    a1, a2, a3 = quat.as_bryant_xyz(q)
    assert a3 == 0.0
    assert a2 == pytest.approx(alpha2, abs=1e-15)
    # at α₂ = +π/2 only α₁ + α₃ is defined, at −π/2 only α₁ − α₃
    assert a1 == pytest.approx(0.8 if alpha2 > 0 else -0.2, abs=1e-15)
    assert quat.attitude_error(q, quat.from_bryant_xyz([a1, a2, a3])) <= 1e-15


# --- batches --------------------------------------------------------------------------------

def test_functions_vectorise_over_batch_dimensions():
    rng = np.random.default_rng(8)
    p = quat.normalize(rng.normal(size=(5, 3, 4)))
    q = quat.normalize(rng.normal(size=(5, 3, 4)))
    v = rng.normal(size=(5, 3, 3))
    batched = {
        'multiply': quat.multiply(p, q), 'exp': quat.exp(v), 'log': quat.log(p),
        'rotate': quat.rotate(p, v), 'matrix': quat.to_matrix(p),
        'from_matrix': quat.from_matrix(quat.to_matrix(p)), 'euler': quat.as_euler_zxz(p),
        'bryant': quat.as_bryant_xyz(p), 'error': quat.attitude_error(p, q),
        'ros': quat.to_ros(p), 'continuous': quat.continuous(p, q)}
    for index in np.ndindex(5, 3):
        single = {
            'multiply': quat.multiply(p[index], q[index]), 'exp': quat.exp(v[index]),
            'log': quat.log(p[index]), 'rotate': quat.rotate(p[index], v[index]),
            'matrix': quat.to_matrix(p[index]),
            'from_matrix': quat.from_matrix(quat.to_matrix(p[index])),
            'euler': quat.as_euler_zxz(p[index]), 'bryant': quat.as_bryant_xyz(p[index]),
            'error': quat.attitude_error(p[index], q[index]), 'ros': quat.to_ros(p[index]),
            'continuous': quat.continuous(p[index], q[index])}
        for name, value in single.items():
            np.testing.assert_allclose(batched[name][index], value, atol=1e-15, err_msg=name)
    assert batched['matrix'].shape == (5, 3, 3, 3)
    assert batched['error'].shape == (5, 3)
    # broadcasting a single quaternion against a batch
    np.testing.assert_allclose(quat.multiply(p[0, 0], q), quat.multiply(
        np.broadcast_to(p[0, 0], q.shape), q), atol=0)


# --- conventions ----------------------------------------------------------------------------

def test_convention_q_maps_body_to_world():
    # a body turned 90° about world z: its x axis points along world y
    q = quat.exp(0.5 * np.pi * E_Z)
    np.testing.assert_allclose(quat.rotate(q, E_X), E_Y, atol=ROUND_OFF)
    np.testing.assert_allclose(quat.to_matrix(q) @ E_X, E_Y, atol=ROUND_OFF)
    np.testing.assert_allclose(quat.rotate_inverse(q, E_Y), E_X, atol=ROUND_OFF)
    # composition q1 ⊗ q2: first q2 (in the body), then q1: x →(z 90°)→ y →(x 90°)→ z
    q_composed = quat.multiply(quat.exp(0.5 * np.pi * E_X), q)
    np.testing.assert_allclose(quat.rotate(q_composed, E_X), E_Z, atol=ROUND_OFF)


def central_difference(function, t, delta=1e-5):
    # truncation δ²|q'''|/6 ≈ 2e−11 for |ω| ≲ 1.5, round-off 1e−16/δ = 1e−11
    return (function(t + delta) - function(t - delta)) / (2.0 * delta)


def test_convention_poisson_rates_are_body_frame():
    omega_body = np.array([0.3, -1.2, 0.5])
    q0 = quat.normalize([0.9, 0.1, -0.3, 0.2])
    t = 0.7

    def composed(s):
        return quat.multiply(q0, quat.exp(omega_body * s))

    for label, q_of_t in (('exp(ω t)', lambda s: quat.exp(omega_body * s)),
                          ('q0 ⊗ exp(ω t)', composed)):
        # ω constant in body axes: q̇ = ½ q ⊗ (0, ω_body)
        derivative = central_difference(q_of_t, t)
        np.testing.assert_allclose(derivative, quaternion_rate(q_of_t(t), omega_body),
                                   atol=1e-9, err_msg=label)
    # the same motion seen in the world frame: q̇ = ½ (0, R ω_body) ⊗ q; the body-frame form
    # with the world vector would be wrong
    q = quat.multiply(q0, quat.exp(omega_body * t))
    omega_world = quat.rotate(q, omega_body)
    derivative = central_difference(composed, t)
    np.testing.assert_allclose(derivative, 0.5 * quat.multiply(np.r_[0.0, omega_world], q),
                               atol=1e-9)
    assert np.max(np.abs(derivative - quaternion_rate(q, omega_world))) > 0.01


def test_ros_order_round_trip():
    q = np.array([0.1, 0.2, 0.3, 0.4])
    np.testing.assert_array_equal(quat.to_ros(q), [0.2, 0.3, 0.4, 0.1])
    np.testing.assert_array_equal(quat.from_ros([0.2, 0.3, 0.4, 0.1]), q)
    batch = random_quaternions(7)
    np.testing.assert_array_equal(quat.from_ros(quat.to_ros(batch)), batch)


def test_canonical_picks_nonnegative_w():
    q = np.array([[-0.5, 0.5, 0.5, 0.5], [0.5, -0.5, 0.5, 0.5]])
    np.testing.assert_array_equal(quat.canonical(q), [[0.5, -0.5, -0.5, -0.5], q[1]])


def test_continuous_keeps_stream_without_jumps():
    # a rotation sweeping through w = 0, with every other sample flipped in sign
    angles = np.linspace(0.0, 3.0 * np.pi, 60)
    stream = quat.exp(angles[:, None] * E_Y)
    stream[1::2] *= -1.0
    previous = stream[0]
    output = [previous]
    for q in stream[1:]:
        previous = quat.continuous(q, previous)
        output.append(previous)
    output = np.array(output)
    steps = np.linalg.norm(np.diff(output, axis=0), axis=-1)
    # neighbours are 3π/59 apart in angle: |Δq| = 2 sin(Δθ/4) ≈ 0.08, never a jump of ~2
    assert np.max(steps) <= 2.0 * math.sin(3.0 * np.pi / 59 / 4) + 1e-12
    np.testing.assert_allclose(np.abs(output), np.abs(stream), atol=0)


def test_attitude_error_sign_invariant_and_exact():
    p = quat.exp([0.3, -0.2, 0.1])
    q = quat.multiply(p, quat.exp([0.0, 0.2, 0.0]))
    for a, b in ((p, q), (-p, q), (p, -q), (-p, -q), (q, p)):
        assert quat.attitude_error(a, b) == pytest.approx(0.2, rel=1e-15)
    near_pi = quat.multiply(p, quat.exp([0.0, 0.0, np.pi - 1e-8]))
    assert quat.attitude_error(p, near_pi) == pytest.approx(np.pi - 1e-8, rel=1e-15)
    assert quat.attitude_error(p, p) <= 1e-16


# --- errors -----------------------------------------------------------------------------------

@pytest.mark.parametrize('call, message', [
    (lambda: quat.normalize([1.0, 2.0, 3.0]), 'Expected `q` to have shape (..., 4), got (3,)'),
    (lambda: quat.conjugate(np.zeros((2, 5))), 'Expected `q` to have shape (..., 4), got (2, 5)'),
    (lambda: quat.multiply([1, 0, 0, 0], [1, 0, 0]),
     'Expected `q` to have shape (..., 4), got (3,)'),
    (lambda: quat.multiply(2.0, [1, 0, 0, 0]), 'Expected `p` to have shape (..., 4), got ()'),
    (lambda: quat.exp([1.0, 2.0]),
     'Expected `rotation_vector` to have shape (..., 3), got (2,)'),
    (lambda: quat.exp([1.0, np.nan, 0.0]), 'Expected `rotation_vector` to be finite, got'),
    (lambda: quat.log([1.0, np.inf, 0.0, 0.0]), 'Expected `q` to be finite, got'),
    (lambda: quat.rotate([1, 0, 0, 0], [1, 2]), 'Expected `v` to have shape (..., 3), got (2,)'),
    (lambda: quat.as_quaternion('abc', 'attitude'),
     "Expected `attitude` to be numeric with shape (..., 4), got 'abc'"),
    (lambda: quat.from_matrix(np.eye(4)), 'Expected `matrix` to have shape (..., 3, 3), got'),
    (lambda: quat.from_matrix(np.full((3, 3), np.nan)), 'Expected `matrix` to be finite'),
    (lambda: quat.from_euler_zxz([0.1, 0.2]), 'Expected `angles` to have shape (..., 3)'),
    (lambda: quat.from_ros([0, 0, 1]), 'Expected `xyzw` to have shape (..., 4), got (3,)'),
    (lambda: quat.continuous([1, 0, 0, 0], [1, 0]),
     'Expected `previous` to have shape (..., 4), got (2,)'),
])
def test_errors_name_argument_and_shape(call, message):
    with pytest.raises(InputError, match=re.escape(message)):
        call()


def test_input_error_is_value_error():
    with pytest.raises(ValueError, match=re.escape('Expected `q` to be finite, got [nan, ')):
        quat.normalize([np.nan, 0.0, 0.0, 1.0])


def test_scalar_exp_step_matches_array_version():
    q = tuple(quat.normalize([0.7, 0.1, -0.2, 0.3]))
    for omega in ((0.3, -0.2, 0.9), (1e-7, 0.0, 2e-7), (0.0, 0.0, 0.0)):
        expected = quat.multiply(q, quat.exp(0.01 * np.array(omega)))
        np.testing.assert_allclose(quat.scalar_exp_step(q, omega, 0.01), expected,
                                   atol=ROUND_OFF)


def test_from_rpy_turns_about_z_then_y_then_x():
    """REP-103 / tf2's setRPY: Rz(yaw) Ry(pitch) Rx(roll); the closed form of the product, the
    inverse Bryant rotation by -rpy, and a batch give the same quaternions."""
    roll, pitch, yaw = 0.3, -0.2, 1.1
    q = quat.from_rpy([roll, pitch, yaw])
    cr, sr = math.cos(0.5 * roll), math.sin(0.5 * roll)
    cp, sp = math.cos(0.5 * pitch), math.sin(0.5 * pitch)
    cy, sy = math.cos(0.5 * yaw), math.sin(0.5 * yaw)
    closed_form = [cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
                   cy * sp * cr + sy * cp * sr, sy * cp * cr - cy * sp * sr]
    np.testing.assert_allclose(q, closed_form, rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(q, quat.conjugate(quat.from_bryant_xyz([-roll, -pitch, -yaw])),
                               rtol=0, atol=ROUND_OFF)
    x_turned = quat.rotate(q, [1.0, 0.0, 0.0])  # x turned by roll (nothing), pitch, then yaw
    np.testing.assert_allclose(x_turned, [math.cos(yaw) * math.cos(pitch),
                                          math.sin(yaw) * math.cos(pitch), -math.sin(pitch)],
                               atol=ROUND_OFF)
    batch = quat.from_rpy([[roll, pitch, yaw], [0.0, 0.0, 0.5]])
    assert batch.shape == (2, 4)
    np.testing.assert_array_equal(batch[0], q)
    with pytest.raises(InputError, match='`angles`'):
        quat.from_rpy([0.1, 0.2])
