"""Hard case 9: property-based tests over random inertia, states and steps (docs/hard-cases.md §9).

Hypothesis draws bodies (principal moments with J₁ + J₂ ≥ J₃ and J₃/J₁ ≤ 10, rotated by a
random attitude, so full tensors too), attitudes, rates up to 10 rad/s and steps with
h|ω| ≤ 0.5, and checks for every dynamics and strapdown method:

* the attitude stays a unit quaternion (| |q| − 1 | ≤ 1e−12);
* torque-free, T and world H stay within the method's bound: round-off (N·16ε) for what the
  method keeps exactly, otherwise its local error summed over the steps, K·N·(κ h|ω|)^(p+1)
  with K = 1 (the local error constant of a p-th order method on a rotation, 1/(p+1)!, is
  far smaller) and κ = J₃/J₁, for steps with κ h|ω| ≤ 0.5 (so an error of lower order than
  claimed, N (κ h|ω|)², would exceed the bound);
* constant-rate composition q(t₁ + t₂) = q(t₁) ⊗ exp(ω t₂) for the strapdown path, the
  kinematics and the exact solution of a body spinning about a principal axis;
* a stream replayed in two halves equals the stream replayed whole, bit for bit: gyro streams
  with the stream and propagator objects carried over (the method's sample history
  included), dynamics clock ticks with a new propagator given only the public state.

Settings: derandomize=True (the same examples on every run, reproducible in CI), no deadline,
a modest number of examples per property.
"""

import copy
import math

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np

from rigid_body_attitude.core.attitude import kinematics
from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.euler import RigidBodyModel
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.attitude.integrators import STRAPDOWN_METHODS, strapdown_method
from rigid_body_attitude.core.dynamics.integrators import DYNAMICS_INTEGRATORS, dynamics_integrator
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import TorqueFreeMotion
from rigid_body_attitude.core.propagator import DynamicsPropagator, GyroPropagator
from rigid_body_attitude.core.dynamics.scene import load_scene, scene_from_mapping
from rigid_body_attitude.session.stream import ClockDriver, GyroStream

EPS = np.finfo(float).eps
PROPERTY = settings(derandomize=True, deadline=None, max_examples=60, database=None,
                    suppress_health_check=[HealthCheck.too_slow])
#: The dynamics property covers ten methods: more examples.
MANY = settings(PROPERTY, max_examples=300)

#: Methods that keep |m| and world H exactly (exact sub-flows) and the order of each method.
EXACT_ROTATION = {'strang', 'yoshida4', 'casimir6', 'casimir8', 'rkn4', 'rkn6', 'exact'}
#: Global orders; the energy of the splitting methods is only bounded (their order), world H
#: of the Runge–Kutta methods drifts at their order.
ORDER = {'rk4': 4, 'rkmk4': 4, 'dopri45': 4, 'strang': 2, 'yoshida4': 4, 'casimir6': 6,
         'casimir8': 8, 'rkn4': 4, 'rkn6': 6, 'exact': 99}

finite = dict(allow_nan=False, allow_infinity=False)


def numbers(low, high):
    """Floats in [low, high], zero, tiny (1e−300) and subnormal magnitudes included."""
    return st.floats(low, high, **finite)


unit_quaternions = st.lists(numbers(-1.0, 1.0), min_size=4, max_size=4).filter(
    lambda v: np.linalg.norm(v) > 0.1).map(lambda v: quat.normalize(v))
rates = st.lists(numbers(-10.0, 10.0), min_size=3, max_size=3).map(np.array)


@st.composite
def bodies(draw):
    """A valid inertia tensor: moments 1 ≤ J₁ ≤ J₂ ≤ J₃ ≤ min(J₁ + J₂, 10 J₁), rotated."""
    j1 = draw(st.floats(1.0, 3.0, **finite))
    j2 = draw(st.floats(j1, 3.0 * j1, **finite))
    j3 = draw(st.floats(j2, min(j1 + j2, 10.0 * j1), **finite))
    rotation = quat.to_matrix(draw(unit_quaternions))
    full = draw(st.booleans())
    tensor = rotation @ np.diag([j1, j2, j3]) @ rotation.T if full else np.diag([j1, j2, j3])
    return 0.5 * (tensor + tensor.T)


def test_every_method_is_covered():
    assert set(DYNAMICS_INTEGRATORS) == set(ORDER)


@MANY
@given(tensor=bodies(), attitude=unit_quaternions, omega=rates,
       rotation_per_step=st.floats(0.01, 0.5, **finite), steps=st.integers(1, 60),
       name=st.sampled_from(sorted(DYNAMICS_INTEGRATORS)))
def test_dynamics_methods_keep_norm_and_invariants(tensor, attitude, omega, rotation_per_step,
                                                   steps, name):
    speed = float(np.linalg.norm(omega))
    moments = np.linalg.eigvalsh(tensor)
    stiffness = moments[2] / moments[0]
    h = rotation_per_step / (max(speed, 1e-3) * stiffness)  # κ h|ω| ≤ 0.5: bounds bite
    model = RigidBodyModel(Inertia(tensor))
    q, omega_end = dynamics_integrator(name).integrate(attitude, omega, 0.0, h, steps, model)
    assert abs(np.linalg.norm(q) - 1.0) <= 1e-12
    momentum0 = tensor @ omega
    world0 = quat.rotate(attitude, momentum0)
    world = quat.rotate(q, tensor @ omega_end)
    energy0 = 0.5 * omega @ momentum0
    energy = 0.5 * omega_end @ tensor @ omega_end
    roundoff = steps * 16.0 * EPS * np.linalg.cond(tensor)
    method_error = steps * (stiffness * h * speed) ** (min(ORDER[name], 8) + 1)
    scale = max(np.linalg.norm(momentum0), 1e-300)
    if name in EXACT_ROTATION:
        assert np.linalg.norm(world - world0) <= roundoff * scale
    else:
        assert np.linalg.norm(world - world0) <= (method_error + roundoff) * scale
    if name == 'exact':
        assert abs(energy - energy0) <= roundoff * max(energy0, 1e-300)
    else:
        bounded = (stiffness * h * speed) ** ORDER[name] if name in EXACT_ROTATION else 0.0
        assert abs(energy - energy0) <= (method_error + bounded + roundoff) * energy0 + 1e-300


@PROPERTY
@given(attitude=unit_quaternions, omega=rates, h=st.floats(1e-4, 0.05, **finite),
       first=st.integers(1, 200), second=st.integers(1, 200),
       name=st.sampled_from(sorted(STRAPDOWN_METHODS)))
def test_strapdown_constant_rate_composition(attitude, omega, h, first, second, name):
    # q(t₁ + t₂) = q(t₁) ⊗ exp(ω t₂) for the methods exact at a constant rate (all but Euler
    # and RK4 on q), with q(t₁) itself = q₀ ⊗ exp(ω t₁); round-off ≤ 16ε per step.
    method = strapdown_method(name)
    rate = tuple(omega.tolist())
    q = tuple(attitude.tolist())
    for _ in range(first):
        q = method.propagate(q, rate, rate, h)
    at_first = np.array(q)
    assert abs(np.linalg.norm(at_first) - 1.0) <= 1e-12
    for _ in range(second):
        q = method.propagate(q, rate, rate, h)
    assert abs(np.linalg.norm(q) - 1.0) <= 1e-12
    if name in ('euler_normalize', 'rk4_quaternion'):
        return
    bound = (first + second) * 16.0 * EPS
    assert quat.attitude_error(np.array(q), quat.multiply(
        at_first, quat.exp(omega * (second * h)))) <= bound
    assert quat.attitude_error(at_first, quat.multiply(attitude, quat.exp(omega * (first * h)))
                               ) <= first * 16.0 * EPS


@PROPERTY
@given(attitude=unit_quaternions, omega=rates, t1=st.floats(0.0, 20.0, **finite),
       t2=st.floats(0.0, 20.0, **finite), moments=st.permutations([1.0, 2.0, 2.5]),
       axis=st.integers(0, 2))
def test_exact_and_kinematic_composition_for_a_principal_spin(attitude, omega, t1, t2, moments,
                                                              axis):
    # Spin about a principal axis keeps ω constant, so the exact solution is a constant-rate
    # rotation: q(t₁ + t₂) = q(t₁) ⊗ exp(ω t₂), to the round-off of the angle |ω|(t₁ + t₂).
    spin = np.zeros(3)
    spin[axis] = omega[axis]
    motion = TorqueFreeMotion(moments, attitude, omega_body=spin)
    both = motion.attitude(t1 + t2)
    composed = quat.multiply(motion.attitude(t1), quat.exp(spin * t2))
    angle = abs(spin[axis]) * (t1 + t2)
    assert quat.attitude_error(both, composed) <= 8.0 * EPS * (1.0 + angle)
    stepped = kinematics.exp_map_step(kinematics.exp_map_step(attitude, spin, t1), spin, t2)
    assert quat.attitude_error(both, stepped) <= 8.0 * EPS * (1.0 + angle)


@st.composite
def gyro_streams(draw):
    """Stamps (s) with jitter, duplicates, swaps, gaps and jumps back; rates, some non-finite."""
    count = draw(st.integers(2, 120))
    stamps, values, t = [], [], 100.0
    for _ in range(count):
        kinds = ['step'] * 12 + ['duplicate', 'back', 'gap', 'jump', 'nan']
        kind = draw(st.sampled_from(kinds))
        if kind != 'duplicate' or not stamps:
            t += draw(st.floats(1e-4, 0.02, **finite))
        if kind == 'back':
            t -= draw(st.floats(0.01, 0.5, **finite))
        elif kind == 'gap':
            t += draw(st.floats(0.2, 1.0, **finite))
        elif kind == 'jump':
            t -= draw(st.floats(2.0, 5.0, **finite))
        rate = draw(rates)
        if kind == 'nan':
            rate = rate.copy()
            rate[draw(st.integers(0, 2))] = math.nan
        stamps.append(t)
        values.append(tuple(rate.tolist()))
    return stamps, values


@PROPERTY
@given(stream=gyro_streams(), split=st.floats(0.0, 1.0, **finite),
       name=st.sampled_from(sorted(STRAPDOWN_METHODS)))
def test_gyro_stream_in_two_halves_equals_whole(stream, split, name):
    stamps, values = stream
    scene = load_scene('strapdown').with_overrides(integrator=name)

    def fresh():
        return GyroStream(GyroPropagator(scene), max_dt=0.1, time_jump_threshold=1.0)

    whole = fresh()
    outputs_whole = []
    for stamp, value in zip(stamps, values):
        whole.add(round(stamp * 1e9), value)
        outputs_whole.append(whole.propagator.state.attitude.copy())
    index = int(split * len(stamps))
    first = fresh()
    outputs_halves = []
    for stamp, value in zip(stamps[:index], values[:index]):
        first.add(round(stamp * 1e9), value)
        outputs_halves.append(first.propagator.state.attitude.copy())
    second = copy.deepcopy(first)  # the state carried over: attitude, last sample, history
    for stamp, value in zip(stamps[index:], values[index:]):
        second.add(round(stamp * 1e9), value)
        outputs_halves.append(second.propagator.state.attitude.copy())
    np.testing.assert_array_equal(np.array(outputs_halves), np.array(outputs_whole))
    assert second.total == len(stamps) == whole.total
    assert second.accepted == whole.accepted and second.rejected == whole.rejected
    assert all(abs(np.linalg.norm(q) - 1.0) <= 1e-12 for q in outputs_whole)


@PROPERTY
@given(tensor=bodies(), attitude=unit_quaternions, omega=rates,
       ticks=st.lists(st.floats(1e-3, 0.05, **finite), min_size=2, max_size=40),
       split=st.floats(0.0, 1.0, **finite),
       name=st.sampled_from(['rk4', 'rkmk4', 'strang', 'yoshida4', 'casimir6']))
def test_dynamics_ticks_in_two_halves_equal_whole(tensor, attitude, omega, ticks, split, name):
    # The node advances a dynamics scene to each clock tick. Stopping after any tick and
    # going on with a new propagator that gets only the public state (time, attitude, rate)
    # gives the run without the stop, bit for bit: the propagator ends exactly on each tick,
    # so the step sequence is the same, and the integrators keep no other history.
    scene = scene_from_mapping({
        'rate_source': 'dynamics', 'integrator': name, 'step': 0.004,
        'body': {'inertia': {'tensor': tensor.tolist()}},
        'initial_state': {'attitude': attitude.tolist(), 'omega_body': omega.tolist()}})
    times = np.cumsum([0.0] + ticks)
    whole = ClockDriver(DynamicsPropagator(scene), time_jump_threshold=1.0)
    for t in times:
        whole.tick(float(t))
    index = int(split * len(times))
    first = ClockDriver(DynamicsPropagator(scene), time_jump_threshold=1.0)
    for t in times[:index]:
        first.tick(float(t))
    resumed = DynamicsPropagator(scene)
    resumed.state = copy.deepcopy(first.propagator.state)
    second = ClockDriver(resumed, time_jump_threshold=1.0)
    second.started = first.started
    for t in times[index:]:
        second.tick(float(t))
    np.testing.assert_array_equal(second.propagator.state.attitude,
                                  whole.propagator.state.attitude)
    np.testing.assert_array_equal(second.propagator.state.omega_body,
                                  whole.propagator.state.omega_body)
    assert second.propagator.state.time == whole.propagator.state.time
    assert abs(np.linalg.norm(whole.propagator.state.attitude) - 1.0) <= 1e-12
