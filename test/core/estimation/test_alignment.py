"""Levelling from gravity: world axes, the levelled attitude, and the aligner's states."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.alignment import (
    ALIGNED, ALIGNED_WITHOUT_REST, ALIGNING, GravityAligner, levelled_attitude, tilt_angle,
    WAITING, world_up)
from rigid_body_attitude.core.errors import InputError

G = 9.80665
RATE_HZ = 100.0
DT = 1.0 / RATE_HZ


def test_world_up_of_each_axes_convention():
    assert world_up('enu') == (0.0, 0.0, 1.0)
    assert world_up('nwu') == (0.0, 0.0, 1.0)
    assert world_up('ned') == (0.0, 0.0, -1.0)
    with pytest.raises(InputError, match='world_axes.*enu, ned, nwu'):
        world_up('xyz')


def test_levelled_attitude_of_a_level_body_is_the_heading_alone():
    assert levelled_attitude((0.0, 0.0, G)) == pytest.approx((1.0, 0.0, 0.0, 0.0))
    # NED: the accelerometer of a level body reads −g along z (up is −z).
    assert levelled_attitude((0.0, 0.0, -G), world_axes='ned') == pytest.approx(
        (1.0, 0.0, 0.0, 0.0))
    yawed = levelled_attitude((0.0, 0.0, G), yaw=0.5)
    assert yawed == pytest.approx((math.cos(0.25), 0.0, 0.0, math.sin(0.25)))


def test_levelled_attitude_roll_about_x_by_hand():
    # Rolled by +30° about x (ENU): world up seen in the body is Rx(30°)ᵀ (0, 0, 1) =
    # (0, sin 30°, cos 30°), so f = g (0, 0.5, 0.8660...).
    q = levelled_attitude((0.0, 0.5 * G, math.sqrt(0.75) * G))
    assert q == pytest.approx((math.cos(math.radians(15)), math.sin(math.radians(15)), 0.0, 0.0))


@pytest.mark.parametrize('world_axes', ['enu', 'nwu', 'ned'])
def test_levelled_attitude_puts_the_specific_force_along_world_up(world_axes):
    rng = np.random.default_rng(11)
    up = np.array(world_up(world_axes))
    for _ in range(20):
        truth = quaternion.normalize(rng.standard_normal(4))
        force = G * quaternion.rotate_inverse(truth, up)
        q = levelled_attitude(tuple(force.tolist()), yaw=float(rng.uniform(-3, 3)),
                              world_axes=world_axes)
        np.testing.assert_allclose(quaternion.rotate(q, force), G * up, atol=1e-12)
        assert tilt_angle(q, tuple(truth.tolist()), world_axes) < 1e-7


def test_levelled_attitude_refuses_zero_and_non_finite_input():
    with pytest.raises(InputError, match='non-zero specific force'):
        levelled_attitude((0.0, 0.0, 0.0))
    with pytest.raises(InputError, match='finite'):
        levelled_attitude((0.0, 0.0, G), yaw=math.inf)


def _tilted_rest(seconds: float, rng, roll=0.3, pitch=-0.2, bias=(0.01, -0.005, 0.002)):
    truth = tuple(quaternion.multiply(quaternion.exp([0.0, pitch, 0.0]),
                                      quaternion.exp([roll, 0.0, 0.0])).tolist())
    count = int(seconds * RATE_HZ)
    force = G * quaternion.rotate_inverse(truth, [0.0, 0.0, 1.0])
    gyro = np.asarray(bias) + 2e-3 * rng.standard_normal((count, 3))
    acc = force + 0.03 * rng.standard_normal((count, 3))
    return truth, gyro, acc


def _run(aligner, gyro, acc):
    states = []
    for w, a in zip(gyro.tolist(), acc.tolist()):
        aligner.update(*w, *a, DT)
        states.append(aligner.state)
    return states


def test_update_waits_aligns_and_levels_a_tilted_body_at_rest():
    rng = np.random.default_rng(12)
    truth, gyro, acc = _tilted_rest(3.0, rng)
    aligner = GravityAligner(align_seconds=1.0, initial_yaw=0.0)
    assert aligner.status.startswith('waiting for rest')
    states = _run(aligner, gyro, acc)
    assert states[0] == WAITING and ALIGNING in states and states[-1] == ALIGNED
    # Window 0.25 s then 1 s of averaging.
    assert states.index(ALIGNED) == pytest.approx(125, abs=3)
    assert aligner.done and aligner.status.startswith('aligned at rest')
    # 100 samples with 0.03 m/s² noise: tilt noise 0.03/√100/9.8 = 3e-4 rad.
    assert tilt_angle(aligner.attitude, truth) < 1.5e-3
    np.testing.assert_allclose(aligner.gyro_bias, (0.01, -0.005, 0.002), atol=1e-3)


def test_status_texts_while_waiting_and_aligning():
    rng = np.random.default_rng(13)
    _, gyro, acc = _tilted_rest(0.8, rng)
    aligner = GravityAligner(align_seconds=1.0)
    _run(aligner, gyro[:10], acc[:10])
    assert aligner.status.startswith('waiting for rest (0.1/10 s): collecting')
    _run(aligner, gyro[10:], acc[10:])
    # Rest from the 25th sample (a full 0.25 s window): 56 samples averaged.
    assert aligner.status == 'aligning 0.6/1 s'
    gyro = gyro + [0.5, 0.0, 0.0]  # motion
    _run(aligner, gyro[:5], acc[:5])
    assert aligner.state == WAITING
    assert aligner.status == ('waiting for rest (0.9/10 s): gyro spread 0.201 rad/s above '
                              'threshold 0.00623')


def test_update_restarts_the_window_when_the_rest_is_broken():
    rng = np.random.default_rng(14)
    _, gyro, acc = _tilted_rest(4.0, rng)
    gyro[80:100, 1] += 1.0  # a short motion inside what would be the first window
    aligner = GravityAligner(align_seconds=1.0)
    states = _run(aligner, gyro, acc)
    # Rest again when the window (25 samples) holds no motion sample: sample 100 + 24; then
    # 100 samples (1 s) averaged.
    assert states.index(ALIGNED) == 100 + 24 + 99
    assert aligner.state == ALIGNED


def test_update_aligns_a_body_that_never_rests_after_the_timeout():
    rng = np.random.default_rng(15)
    truth, gyro, acc = _tilted_rest(6.0, rng, roll=0.1, pitch=0.0)
    t = np.arange(len(gyro)) * DT
    gyro[:, 2] += 0.5 + 0.4 * np.sin(3.0 * t)  # yawing all the time: tilt unchanged
    aligner = GravityAligner(align_seconds=1.0, align_timeout=5.0)
    states = _run(aligner, gyro, acc)
    assert ALIGNING not in states
    assert states.index(ALIGNED_WITHOUT_REST) == pytest.approx(499, abs=1)
    assert 'without rest after timeout' in aligner.status
    assert aligner.gyro_bias == (0.0, 0.0, 0.0)
    assert tilt_angle(aligner.attitude, truth) < 2e-3


def test_update_without_accelerometer_starts_level_after_the_timeout():
    aligner = GravityAligner(align_timeout=1.0, world_axes='ned')
    for _ in range(150):
        aligner.update(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, DT)
    assert aligner.state == ALIGNED_WITHOUT_REST
    assert aligner.attitude == pytest.approx((1.0, 0.0, 0.0, 0.0))


def test_reset_waits_for_rest_again():
    rng = np.random.default_rng(16)
    _, gyro, acc = _tilted_rest(2.0, rng)
    aligner = GravityAligner()
    _run(aligner, gyro, acc)
    assert aligner.done
    aligner.reset()
    assert aligner.state == WAITING and not aligner.done


def test_gravity_aligner_refuses_bad_arguments():
    with pytest.raises(InputError, match='align_seconds'):
        GravityAligner(align_seconds=-1.0)
    with pytest.raises(InputError, match='align_timeout'):
        GravityAligner(align_timeout=math.nan)
    with pytest.raises(InputError, match='initial_yaw'):
        GravityAligner(initial_yaw=math.inf)
    with pytest.raises(InputError, match='world_axes'):
        GravityAligner(world_axes='END')
