"""dynamics.rk4_step is the ``rk4`` integrator's step on arrays (one RK4 implementation)."""

import math

import numpy as np

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.euler import rk4_step, RigidBodyModel
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.dynamics.integrators import dynamics_integrator


def test_rk4_step_is_the_rk4_integrator_step():
    def torque(t, attitude, omega_body):
        return np.array([0.2 * math.sin(t), -0.1 * omega_body[0], attitude[1]])

    def rotor(t):
        return np.array([0.0, 0.3 + 0.1 * t, 0.0]), np.array([0.0, 0.1, 0.0])
    model = RigidBodyModel(Inertia([[2.0, 0.1, 0.0], [0.1, 3.0, -0.2], [0.0, -0.2, 4.0]]),
                           (torque,), (rotor,))
    attitude, omega = quat.normalize([0.7, -0.1, 0.4, 0.2]), np.array([0.9, -1.2, 2.5])
    integrator = dynamics_integrator('rk4')
    for k in range(50):
        expected_q, expected_omega = integrator.step(attitude, omega, 0.02 * k, 0.02, model)
        attitude, omega = rk4_step(model, 0.02 * k, attitude, omega, 0.02)
        # Same stages, same floats; only the final renormalisation (q/|q| vs q·(1/|q|))
        # may differ, by an ulp.
        np.testing.assert_array_equal(omega, expected_omega)
        np.testing.assert_allclose(attitude, expected_q, rtol=0.0, atol=4e-16)
