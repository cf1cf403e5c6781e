"""The GNC loop of three sessions in one process (``test/gnc_loop.py``): a star tracker sample
reaching the estimator before or after the gyro sample of its instant changes nothing.

Over ROS the two come on two topics, in either order; the estimator fuses a star tracker
sample at the gyro state of its stamp, before the next gyro sample, whichever came first, so
the estimates and the wheel commands are the same bits (``test/ros/test_gnc_loop.py`` runs
the three processes against this loop).
"""

from gnc_loop import gnc_loop, TICK_RATE


def test_the_loop_is_the_same_whichever_sample_comes_first():
    first, second = gnc_loop(3.0, star_first=True), gnc_loop(3.0, star_first=False)
    assert len(first.estimates) == len(first.commands) == 3 * int(TICK_RATE) + 1
    assert first.estimates == second.estimates
    assert first.commands == second.commands
    assert first.truth == second.truth
