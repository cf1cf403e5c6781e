"""The estimation study's error split: BROAD's (Laidig et al. 2021, section 4), a turn about
the world's vertical all heading, a turn about a horizontal axis all inclination."""

import math

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.tools.estimation_study import broad_errors


def test_broad_errors_split_heading_from_inclination():
    reference = quaternion.from_rpy([0.3, -0.2, 1.1])[None, :]
    about_up = quaternion.multiply(quaternion.from_rpy([0.0, 0.0, math.radians(10.0)]),
                                   reference)
    about_east = quaternion.multiply(quaternion.from_rpy([math.radians(4.0), 0.0, 0.0]),
                                     reference)
    # acos near 1: a round-off of 1e-16 in its argument is 1.5e-8 rad (1e-6 deg)
    np.testing.assert_allclose(np.degrees(broad_errors(about_up, reference)), [[10, 10, 0]],
                               atol=1e-5)
    np.testing.assert_allclose(np.degrees(broad_errors(about_east, reference)), [[4, 0, 4]],
                               atol=1e-5)
