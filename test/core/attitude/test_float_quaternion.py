"""The plain-float quaternion helpers against the NumPy quaternion algebra."""

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.attitude.float_quaternion import q_exp, q_multiply, q_rotate_step


def test_float_helpers_agree_with_the_array_algebra():
    q = tuple(quaternion.normalize([0.9, -0.1, 0.3, 0.2]).tolist())
    v = (0.02, -0.5, 0.7)
    assert np.allclose(q_multiply(q, q_exp(*v)),
                       quaternion.multiply(q, quaternion.exp(v)), rtol=0.0, atol=1e-15)
    assert np.allclose(q_rotate_step(q, *v), quaternion.multiply(q, quaternion.exp(v)),
                       rtol=0.0, atol=1e-15)
    assert np.allclose(q_exp(1e-9, 0.0, 0.0), quaternion.exp([1e-9, 0.0, 0.0]),
                       rtol=0.0, atol=1e-20)
