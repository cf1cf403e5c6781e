"""Hostile accelerometer samples while levelling, through the gyro session's Imu handler.

A finite but absurd specific force (far beyond any accelerometer's range) during the rest
window must be refused and counted before it reaches the rest detector's windowed sums: the
levelling then completes from the clean samples with the true tilt; a stream of them leaves
the diagnostics naming why nothing levels. No sample is ever an ``internal_error``.
"""

import math
import random

import numpy as np
import pytest
from conftest import BASE_NS, MS

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.alignment import tilt_angle, world_up
from rigid_body_attitude.core.estimation.rest import SPECIFIC_FORCE_LIMIT
from rigid_body_attitude.msgs import encode_imu
from rigid_body_attitude.session.decoding import input_handler
from rigid_body_attitude.session.reports import LEVEL_OK
from rigid_body_attitude.core.attitude.quaternion import from_rpy


def rpy(*angles):
    """``from_rpy`` of roll, pitch, yaw as a (w, x, y, z) tuple."""
    return tuple(from_rpy(angles).tolist())


G = 9.80665
PERIOD_NS = 5 * MS  # 200 Hz
TRUTH = rpy(0.3, -0.2, 0.0)


def rest_accel():
    up = np.array(world_up('enu')) * G
    return tuple(quaternion.rotate_inverse(TRUTH, up).tolist())


def rest_imus(count, rng, start=0):
    accel = rest_accel()
    for k in range(start, start + count):
        rate = tuple(rng.gauss(0.0, 0.003) for _ in range(3))
        acc = tuple(a + rng.gauss(0.0, 0.03) for a in accel)
        yield BASE_NS + k * PERIOD_NS, rate, acc


@pytest.mark.parametrize('absurd', [(1e200, 0.0, 0.0), (0.0, -1e155, 0.0),
                                    (0.0, 0.0, 1e154), (0.0, 0.0, 1.5 * SPECIFIC_FORCE_LIMIT),
                                    (1e308, 1e308, 1e308)])  # (a sum that overflows)
def test_one_absurd_specific_force_is_refused_and_levelling_keeps_the_tilt(open_scene, clocks,
                                                                           absurd):
    session, sink = open_scene('strapdown')
    handle = input_handler(session, 'imu')
    samples = list(rest_imus(400, random.Random(7)))
    for k, (stamp, rate, acc) in enumerate(samples):
        # Inside the first rest window (the detector's window is 0.25 s = 50 samples).
        handle(encode_imu(stamp, 'imu_link', rate, absurd if k == 30 else acc))
    rejected = session.rejection_counts()
    assert rejected['accel_out_of_range'] == 1
    assert rejected['internal_error'] == 0
    assert session.alignment_done and session.alignment.at_rest
    # The clean samples' tilt: σ 0.03 m/s² over 200 samples, 2.2e-4 rad per axis; 0.05 deg is
    # 4 σ.
    assert math.degrees(tilt_angle(session.alignment.attitude, TRUTH)) < 0.05
    assert sink.attitudes
    assert any('accelerometer' in text and 'out of range' in text for _, text in sink.logs)


def test_finite_rates_whose_sum_overflows_are_out_of_range_while_levelling(open_scene):
    session, _ = open_scene('strapdown')
    handle = input_handler(session, 'imu')
    for k, (stamp, rate, acc) in enumerate(rest_imus(400, random.Random(8))):
        handle(encode_imu(stamp, 'imu_link', (1e308, 1e308, 1e308) if k == 30 else rate, acc))
    rejected = session.rejection_counts()
    assert rejected['out_of_range'] == 1 and rejected['non_finite'] == 0
    assert math.degrees(tilt_angle(session.alignment.attitude, TRUTH)) < 0.05


def test_non_finite_specific_force_is_refused_as_non_finite(open_scene):
    session, _ = open_scene('strapdown')
    handle = input_handler(session, 'imu')
    for k, (stamp, rate, acc) in enumerate(rest_imus(400, random.Random(8))):
        handle(encode_imu(stamp, 'imu_link', rate, (math.nan, 0.0, G) if k == 30 else acc))
    rejected = session.rejection_counts()
    assert rejected['non_finite'] == 1 and rejected['internal_error'] == 0
    assert math.degrees(tilt_angle(session.alignment.attitude, TRUTH)) < 0.05


def test_a_stream_of_absurd_samples_says_why_nothing_levels(open_scene, clocks):
    session, sink = open_scene('strapdown', align_timeout=2.0)
    handle = input_handler(session, 'imu')
    for k, (stamp, rate, _) in enumerate(rest_imus(1000, random.Random(9))):
        handle(encode_imu(stamp, 'imu_link', rate, (0.0, 0.0, 1e300)))
        if k % 200 == 199:
            clocks.monotonic += 1.0
            report = session.report()
            assert report.level != LEVEL_OK
            assert 'accel_out_of_range' in report.message, report.message
            assert 'aligning' in report.message
    rejected = session.rejection_counts()
    assert rejected['accel_out_of_range'] == 1000
    assert rejected['internal_error'] == 0
    assert not sink.attitudes and not session.alignment_done
    assert session.missed_count() == 0
    # Clean samples afterwards level as usual.
    for stamp, rate, acc in rest_imus(400, random.Random(10), start=1000):
        handle(encode_imu(stamp, 'imu_link', rate, acc))
    assert session.alignment_done and session.alignment.at_rest
    assert math.degrees(tilt_angle(session.alignment.attitude, TRUTH)) < 0.05
    assert session.rejection_counts()['internal_error'] == 0


def test_absurd_specific_force_after_levelling_with_refinement_is_refused(open_scene):
    """With ``refine_bias_at_rest`` the accelerometer feeds the rest detector after levelling:
    the same check holds there, and the gyro sample is integrated no more than its neighbours
    would be."""
    session, sink = open_scene('strapdown', refine_bias_at_rest=True)
    handle = input_handler(session, 'imu')
    feed = list(rest_imus(800, random.Random(11)))
    for k, (stamp, rate, acc) in enumerate(feed):
        handle(encode_imu(stamp, 'imu_link', rate, (0.0, 1e200, 0.0) if k == 500 else acc))
    rejected = session.rejection_counts()
    assert rejected['accel_out_of_range'] == 1 and rejected['internal_error'] == 0
    bias = session.sample_map.gyro_bias
    assert all(math.isfinite(b) and abs(b) < 2e-3 for b in bias)
    assert session.missed_count() == 0
