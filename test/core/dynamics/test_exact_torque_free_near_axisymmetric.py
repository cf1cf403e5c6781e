"""The exact torque-free solution on nearly axisymmetric and generic bodies at t = 1e4 s,
against a 30-digit mpmath reference (issue 14: no accuracy lost to a near-axisymmetric
shortcut; every relative moment difference down to one ulp stays ≤ 1e−10 rad).

The reference is independent of the package's closed form: Landau & Lifshitz's Euler angles
(*Mechanics* §37) about the world angular momentum, with the body momentum from mpmath's
Jacobi functions and the precession angle φ by mpmath quadrature of
``φ̇ = G (m_i²/J_i + m_j²/J_j)/(m_i² + m_j²)`` (``i, j`` the axes other than the one the
momentum circulates about), continued over whole periods.
"""

import math

import mpmath
import pytest

from high_precision import mp_attitude_error
from rigid_body_attitude.core.attitude import quaternion as quat
from rigid_body_attitude.core.dynamics.integrators.exact_torque_free import TorqueFreeMotion

DIGITS = 30
DURATION = 1e4
Q0 = quat.normalize([0.8, -0.2, 0.3, 0.4])


def _rotation_z(angle):
    c, s = mpmath.cos(angle), mpmath.sin(angle)
    return mpmath.matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _rotation_x(angle):
    c, s = mpmath.cos(angle), mpmath.sin(angle)
    return mpmath.matrix([[1, 0, 0], [0, c, -s], [0, s, c]])


def _matrix(q):
    w, x, y, z = q
    return mpmath.matrix([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _quaternion(r):
    w = mpmath.sqrt(1 + r[0, 0] + r[1, 1] + r[2, 2]) / 2  # the test rotations are < π/2 off
    return [w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w),
            (r[1, 0] - r[0, 1]) / (4 * w)]


class MpTorqueFree:
    """Attitude of a torque-free body (ascending principal moments = body axes) at DIGITS."""

    def __init__(self, moments, attitude, omega_body):
        mpmath.mp.dps = DIGITS
        j = [mpmath.mpf(float(x)) for x in moments]
        q0 = [mpmath.mpf(float(x)) for x in attitude]
        m = [j[i] * mpmath.mpf(float(omega_body[i])) for i in range(3)]
        twice_energy = sum(m[i] ** 2 / j[i] for i in range(3))
        self.norm = mpmath.sqrt(sum(x * x for x in m))
        delta = [self.norm ** 2 - twice_energy * j[i] for i in range(3)]
        # circulation about the minor (Δ₂ < 0) or the major axis (Landau & Lifshitz, *Mechanics*,
        # 1976, §37)
        a, b, c = (0, 1, 2) if delta[1] < 0 else (2, 1, 0)
        self.axes, self.j = (a, b, c), j
        self.polar = (1, 2, 0) if a == 0 else (0, 1, 2)  # cyclic: right-handed
        self.amplitudes = [mpmath.sqrt(j[a] * delta[c] / (j[a] - j[c])),
                           mpmath.sqrt(j[b] * delta[a] / (j[b] - j[a])),
                           mpmath.sqrt(j[c] * delta[a] / (j[c] - j[a]))]
        self.parameter = 1 - delta[b] * (j[c] - j[a]) / (delta[c] * (j[b] - j[a]))
        self.sign = 1 if m[a] > 0 else -1
        self.rate = self.sign * mpmath.sqrt(delta[c] * (j[a] - j[b]) / (j[0] * j[1] * j[2]))
        amplitude = mpmath.atan2(m[b] / self.amplitudes[1], m[c] / self.amplitudes[2])
        self.u0 = mpmath.ellipf(amplitude, self.parameter)
        self.half_period = 2 * mpmath.ellipk(self.parameter)  # of m_i², m_j², in u
        start = self._momentum(self.u0)
        assert max(abs(start[i] - m[i]) for i in range(3)) < 1e-25 * self.norm
        theta, psi = self._angles(start)
        permutation = mpmath.zeros(3, 3)
        for row, column in enumerate(self.polar):
            permutation[row, column] = 1
        self.permutation = permutation
        self.left = _matrix(q0) * permutation.T * _rotation_z(-psi) * _rotation_x(-theta)
        self.turn = self._precession(self.u0, self.u0 + self.half_period)

    def _momentum(self, u):
        a, b, c = self.axes
        m = [0, 0, 0]
        m[a] = self.sign * self.amplitudes[0] * mpmath.ellipfun('dn', u, self.parameter)
        m[b] = self.amplitudes[1] * mpmath.ellipfun('sn', u, self.parameter)
        m[c] = self.amplitudes[2] * mpmath.ellipfun('cn', u, self.parameter)
        return m

    def _angles(self, m):
        first, second, polar = (m[i] for i in self.polar)
        return mpmath.acos(polar / self.norm), mpmath.atan2(first, second)

    def _precession_rate(self, u):
        m = self._momentum(u)
        i, k = self.polar[:2]
        return self.norm * (m[i] ** 2 / self.j[i] + m[k] ** 2 / self.j[k]) / (
            m[i] ** 2 + m[k] ** 2)

    def _precession(self, u_from, u_to):
        """``φ(u_to) − φ(u_from) = ∫ φ̇ du/λ``."""
        return mpmath.quad(self._precession_rate, mpmath.linspace(u_from, u_to, 5)) / self.rate

    def attitude(self, t):
        """q(t) as DIGITS-digit numbers (w, x, y, z)."""
        u = self.u0 + self.rate * mpmath.mpf(float(t))
        turns = int(mpmath.floor(abs(u - self.u0) / self.half_period))
        base = self.u0 + mpmath.sign(self.rate) * turns * self.half_period
        phi = turns * self.turn + self._precession(base, u)
        theta, psi = self._angles(self._momentum(u))
        rotation = (self.left * _rotation_z(phi) * _rotation_x(theta) * _rotation_z(psi)
                    * self.permutation)
        return _quaternion(rotation)


def test_reference_agrees_with_the_closed_form_at_one_second():
    # The two independent constructions agree at round-off after one second: the reference's
    # conventions (Euler angles, signs, axis order) are those of TorqueFreeMotion.
    moments, omega = [0.6, 0.8, 1.0], [3.0, 0.5, -0.9]
    reference = MpTorqueFree(moments, Q0, omega)
    q = TorqueFreeMotion(moments, Q0, omega_body=omega).attitude(1.0)
    assert mp_attitude_error(q, reference.attitude(1.0)) <= 5e-15


@pytest.mark.parametrize('delta', [1e-4, 1e-10, 1e-12, 1e-14, 'ulp', 0.0])
@pytest.mark.parametrize('shape, omega_body', [
    ('oblate', [0.3, -0.4, 1.1]),    # J₁ ≈ J₂ < J₃, m 22° from the symmetry axis
    ('prolate', [1.3, 0.2, -0.4]),   # J₁ < J₂ ≈ J₃, m 20° from the symmetry axis
    ('oblate', [1.0, 0.2, 0.05]),    # J₁ ≈ J₂, m 87° from the symmetry axis
])
def test_state_nearly_axisymmetric_at_1e4_s(delta, shape, omega_body):
    # J₁ = 1, J₂ = 1 + δ, J₃ = 2 (oblate) or J₁ = 1, J₂ = 2, J₃ = 2(1 + δ) (prolate); 'ulp'
    # is the next double above the moment. Until issue 14, δ ≤ 1e−10 with m near the symmetry
    # axis took the axisymmetric form with the harmonic mean: 3.7e−9 rad at 1e4 s. Measured
    # now ≤ 4.7e−12 rad for every δ (the elliptic form below any δ > 0); bound 1e−10.
    low = 1.0 if shape == 'oblate' else 2.0
    high = math.nextafter(low, 2.0 * low) if delta == 'ulp' else low * (1.0 + delta)
    moments = [1.0, high, 2.0] if shape == 'oblate' else [1.0, 2.0, high]
    motion = TorqueFreeMotion(moments, Q0, omega_body=omega_body)
    assert motion.kind == ('axisymmetric' if high == low else
                           ('major_axis' if shape == 'oblate' else 'minor_axis'))
    reference = MpTorqueFree(moments, Q0, omega_body)
    assert mp_attitude_error(motion.attitude(DURATION), reference.attitude(DURATION)) <= 1e-10


@pytest.mark.parametrize('moments, omega_body', [
    ([0.6, 0.8, 1.0], [3.0, 0.5, -0.9]),   # Hairer–Vilmart body (J. Phys. A 39, 2006)
    ([1.0, 2.0, 3.0], [1.0, 0.2, 0.3]),    # minor-axis circulation
    ([1.0, 2.0, 3.0], [0.2, 0.3, 1.0]),    # major-axis circulation
])
def test_state_generic_bodies_at_1e4_s(moments, omega_body):
    # The double-precision floor: ψ(1e4 s) ≈ 3e4 rad carries ~ε·3e4 = 7e−12 rad of rounding in
    # its phase alone; measured 3.3e−12, 2.8e−12, 2.2e−12 rad. Bound 6.4e−12 (issue 14).
    motion = TorqueFreeMotion(moments, Q0, omega_body=omega_body)
    reference = MpTorqueFree(moments, Q0, omega_body)
    assert mp_attitude_error(motion.attitude(DURATION), reference.attitude(DURATION)) <= 6.4e-12
