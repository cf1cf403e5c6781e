"""Propagated scenes and the splitting integrators: what the body model declares to them.

The propagator's :class:`~rigid_body_attitude.core.dynamics.euler.RigidBodyModel` says whether any
torque
uses the body rate (``torque_depends_on_rate``, from the effects) and whether a rotor acts
(``has_rotor``); with neither, the splitting methods apply gravity as an exact kick and keep
their order. Reference: DOP853 at rtol 1e−13 on the same model's equations.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.effects import (
    BodyProperties, EFFECTS, Environment, TorqueEffect)
from rigid_body_attitude.core.environment.orbit import CircularOrbit
from rigid_body_attitude.core.environment.tilted_dipole import TiltedDipoleField
from rigid_body_attitude.core.errors import IntegratorError
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.dynamics.euler import RigidBodyModel
from rigid_body_attitude.core.dynamics.integrators import DYNAMICS_INTEGRATORS
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.core.dynamics.scene import scene_from_mapping

BODY = BodyProperties(Inertia([0.5, 0.7, 0.9]), 2.0)
#: Parameters that build each torque effect with a non-zero torque.
TORQUE_EFFECT_PARAMETERS = {
    'attitude_pd': {'kp': 1.0, 'kd': 2.0, 'control_period': 0.1},
    'commanded_torque': {'timeout': 10.0},
    'constant_torque': {'torque': [0.1, -0.2, 0.3]},
    'gravity_about_pivot': {'centre_of_mass': [0.01, -0.02, 0.1]},
    'gravity_gradient': {'orbit_radius': 7.0e6},
    'viscous_damping': {'coefficient': [0.1, 0.2, 0.3]},
    'magnetorquers': {'max_dipole': 1.0},
    'residual_dipole': {'dipole': [0.1, 0.0, -0.2]},
    'bdot': {'gain': 1.0e4, 'control_period': 0.1},
}
#: The torque effects acting through the scene's magnetic field, on this orbit.
ORBIT = CircularOrbit(7.0e6, 1.7)
MAGNETIC_BODY = BodyProperties(Inertia([0.5, 0.7, 0.9]), 2.0,
                               Environment(ORBIT, TiltedDipoleField(ORBIT)))


GRAVITY = {'gravity_about_pivot': {'centre_of_mass': [0.0, 0.0, 0.1]}}


def top_scene(integrator, step, effects=(GRAVITY,)):
    """The shipped heavy top's body and state (spin 50 rad/s, tilt 0.3 rad)."""
    return scene_from_mapping({
        'name': 'top', 'rate_source': 'dynamics', 'integrator': integrator, 'step': step,
        'body': {'mass': 1.0, 'inertia': {'moments': [0.012, 0.012, 0.004]}},
        'initial_state': {'attitude': quat.exp([0.3, 0.0, 0.0]).tolist(),
                          'omega_body': [0.0, 0.0, 50.0]},
        'effects': list(effects)})


def test_effects_declare_whether_their_torque_uses_the_rate():
    torque_effects = sorted(name for name, cls in EFFECTS.items() if issubclass(cls, TorqueEffect))
    assert torque_effects == sorted(TORQUE_EFFECT_PARAMETERS)  # a new torque effect: add it
    attitude = quat.normalize([0.8, 0.1, -0.3, 0.5])
    for name, params in TORQUE_EFFECT_PARAMETERS.items():
        magnetic = name in ('magnetorquers', 'residual_dipole', 'bdot')
        effect = EFFECTS[name](params, MAGNETIC_BODY if magnetic else BODY)
        if name == 'commanded_torque':
            effect.accept_input('torque', 0.0, np.array([0.3, 0.1, -0.2]))
        if name == 'attitude_pd':  # the torque sampled at 0 and held: not of the rate at 1
            effect.sample(0.0, tuple(attitude.tolist()), (0.1, 0.2, 0.3))
        if name == 'magnetorquers':  # a dipole held over the step from 0
            effect.accept_input('dipole', 0.0, np.array([0.3, 0.1, -0.2]))
            effect.hold(0.0, 2.0, tuple(attitude.tolist()), (0.1, 0.2, 0.3))
        slow = effect.torque_body(1.0, attitude, np.array([0.1, 0.2, 0.3]))
        fast = effect.torque_body(1.0, attitude, np.array([-5.0, 3.0, 40.0]))
        if name == 'bdot':  # a dipole for the magnetorquers: no torque of its own
            assert not effect.applies_torque and not np.any(slow) and not np.any(fast)
            assert effect.torque_depends_on_rate is False
            continue
        assert np.any(slow != 0.0), name
        assert effect.torque_depends_on_rate == (not np.array_equal(slow, fast)), name


def test_propagator_model_declares_rate_dependence_and_rotor():
    top = DynamicsPropagator(top_scene('casimir8', 0.01)).model
    assert top.torque_depends_on_rate is False and top.has_rotor is False
    damped = DynamicsPropagator(top_scene('casimir8', 0.01, [
        GRAVITY, {'viscous_damping': {'coefficient': 0.01}}])).model
    assert damped.torque_depends_on_rate is True
    rotor = DynamicsPropagator(top_scene('rk4', 0.01, [
        {'rotor': {'momentum': [0.0, 0.1, 0.0]}}])).model
    assert rotor.has_rotor is True and rotor.torque_depends_on_rate is False


@pytest.mark.parametrize('name, kicks', [('casimir8', 18), ('rkn6', 12)])
def test_propagated_heavy_top_kicks_cost_one_torque_evaluation(name, kicks):
    # Gravity ignores ω and no rotor acts: each kick is exact in one evaluation (a model that
    # may depend on the rate gets RK4 kicks, four evaluations each).
    damping = {'viscous_damping': {'coefficient': 0.0}}
    for effects, evaluations in (([GRAVITY], kicks), ([GRAVITY, damping], 4 * kicks)):
        propagator = DynamicsPropagator(top_scene(name, 0.01, effects))
        model = propagator.model
        calls = []

        def counted(torque):
            def call(t, attitude, omega_body):
                calls.append(t)
                return torque(t, attitude, omega_body)
            return call
        model = RigidBodyModel(model.inertia, float_torques=[counted(f) for f in model.torques],
                               torque_depends_on_rate=model.torque_depends_on_rate)
        propagator.integrator.step(propagator.state.attitude, propagator.state.omega_body, 0.0,
                                   0.01, model)
        assert len(calls) == evaluations * len(effects), effects


@pytest.mark.parametrize('name, steps, order', [('casimir8', (25, 50), 8), ('rkn6', (50, 100), 6)])
def test_propagated_heavy_top_keeps_the_splitting_order(name, steps, order):
    # The propagator's model takes the fused loop with exact kicks; the composition keeps its
    # order on the propagated top.
    model = DynamicsPropagator(top_scene(name, 0.01)).model
    start = np.concatenate([quat.exp([0.3, 0.0, 0.0]), [0.0, 0.0, 50.0]])

    def rhs(t, y):
        q, omega = y[:4], y[4:]
        return np.concatenate([0.5 * quat.multiply(q, np.concatenate([[0.0], omega])),
                               model.omega_dot(t, q, omega)])
    expected = solve_ivp(rhs, (0.0, 1.0), start, method='DOP853', rtol=1e-13,
                         atol=1e-15).y[:4, -1]
    errors = []
    for n in steps:
        propagator = DynamicsPropagator(top_scene(name, 1.0 / n))
        propagator.advance_to(1.0)
        errors.append(quat.attitude_error(propagator.state.attitude, expected))
    measured = math.log(errors[0] / errors[1]) / math.log(steps[1] / steps[0])
    # Errors ≥ 1e−10 against a reference good to ~1e−12 (nutation 17 rad/s, h ≤ 0.04 s).
    assert abs(measured - order) <= 0.3, errors


def test_torque_free_only_integrator_lists_the_torque_integrators():
    torque_capable = sorted(name for name, cls in DYNAMICS_INTEGRATORS.items()
                            if cls.supports_torque)
    assert 'exact' not in torque_capable and 'casimir8' in torque_capable
    with pytest.raises(IntegratorError, match="'exact' handles torque-free bodies only") as info:
        DynamicsPropagator(top_scene('exact', 0.01))
    assert str(info.value).endswith(f'Use one of {", ".join(torque_capable)}')
