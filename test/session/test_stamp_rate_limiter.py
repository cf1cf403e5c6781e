"""StampRateLimiter: ``tf_rate`` transforms per second of stamps, jittered stamps included."""

import numpy as np
import pytest

from rigid_body_attitude.session.outputs import StampRateLimiter

PERIOD_NS = 5_000_000  # a 200 Hz input


def passed(limiter, stamps_ns):
    return [int(s) for s in stamps_ns if limiter.due(int(s))]


@pytest.mark.parametrize('jitter', [0.0, 0.2, 0.4])
def test_a_200_hz_input_with_jittered_stamps_gives_100_per_second(jitter):
    rng = np.random.default_rng(7)
    count = 20_000  # 100 s of stamps
    stamps = np.arange(count) * PERIOD_NS + 10**9
    stamps += (rng.uniform(-jitter, jitter, count) * PERIOD_NS).astype(np.int64)
    sent = passed(StampRateLimiter(100.0), stamps)
    seconds = (stamps[-1] - stamps[0]) / 1e9
    assert abs(len(sent) - 100.0 * seconds) <= 1
    per_second = np.bincount((np.array(sent) - stamps[0]) // 10**9)
    assert per_second[:-1].max() <= 101


def test_exact_stamps_are_sent_on_the_grid_of_the_period():
    stamps = np.arange(1000) * PERIOD_NS
    sent = passed(StampRateLimiter(100.0), stamps)
    assert set(np.diff(sent)) == {10_000_000}
    assert sent[0] == 0


def test_rate_zero_sends_every_stamp():
    stamps = [0, 5, 5, 10, 3]
    assert passed(StampRateLimiter(0.0), stamps) == stamps


def test_a_gap_restarts_the_grid_and_stamps_going_back_are_sent():
    limiter = StampRateLimiter(100.0)
    assert passed(limiter, [0, 5_000_000, 10_000_000]) == [0, 10_000_000]
    # 1 s without samples: the next stamp is sent, the grid restarts there
    assert passed(limiter, [1_010_000_001, 1_015_000_000, 1_020_000_001]) == [
        1_010_000_001, 1_020_000_001]
    assert limiter.due(500_000_000)  # back in time: sent
    assert not limiter.due(505_000_000)
