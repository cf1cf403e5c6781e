"""RK4 steps written out for one body model: the four stages inlined, specialised once.

The classical RK4 step on ``(q, ω)`` with Euler's right-hand side (Landau & Lifshitz, *Mechanics*,
3rd ed., 1976, §36, :mod:`.rigid_body_rk4`) costs, in CPython, mostly the calls and tuples around
its arithmetic: four calls of a generic right-hand side that re-reads the model and tests its flags
each time. :func:`rk4_kernel` writes the step's source once per model with every stage inlined and
only the terms the model has: a diagonal inertia multiplies by three moments instead of a 3×3
tensor (and ``J⁻¹``), a torque-free body calls no torque, a body without rotor asks for none.
The source is compiled with :func:`compile` and cached on the model's kernel key. The
arithmetic is the generic right-hand side's, term by term (with the zero products of a
diagonal tensor left out), so the result is the same up to those exact zeros; the work of the
torques, ``∫ ω·(M − ḣ) dt``, is integrated alongside by the same weights.

``bench/effect_costs.py`` measures the gain against the generic step.
"""

from __future__ import annotations

from collections.abc import Callable

from rigid_body_attitude.core.dynamics.integrators.base import BodyModel, body_derivative_power

__all__ = ['Rk4Kernel', 'rk4_kernel', 'rk4_state_step', 'rk4_work_step']

#: ``(t, y, h) -> (y⁺, work)`` with ``y`` the 7 floats ``(q, ω)`` (no renormalisation).
Rk4Kernel = Callable[[float, tuple[float, ...], float], tuple[tuple[float, ...], float]]

_CACHE: dict[tuple[bool, bool, bool, tuple[float, ...], tuple[float, ...]], Rk4Kernel] = {}


def _stage(name: str, time: str, y: list[str], diagonal: bool, torque: bool,
           rotor: bool) -> list[str]:
    """Source lines computing the derivative ``name0..name7`` at ``(time, y)``."""
    w, x, yy, z, p, q, r = y
    lines = []
    if torque:
        lines.append(f'tx, ty, tz = torque({time}, ({w}, {x}, {yy}, {z}), ({p}, {q}, {r}))')
    else:
        lines.append('tx = ty = tz = 0.0')
    if diagonal:
        lines.append(f'mx, my, mz = j00 * {p}, j11 * {q}, j22 * {r}')
    else:
        lines += [f'mx = j00 * {p} + j01 * {q} + j02 * {r}',
                  f'my = j10 * {p} + j11 * {q} + j12 * {r}',
                  f'mz = j20 * {p} + j21 * {q} + j22 * {r}']
    if rotor:
        lines += [f'(hx, hy, hz), (rx, ry, rz) = rotor({time})',
                  'tx, ty, tz = tx - rx, ty - ry, tz - rz',
                  'mx, my, mz = mx + hx, my + hy, mz + hz']
    lines += [f'bx = tx - ({q} * mz - {r} * my)',
              f'by = ty - ({r} * mx - {p} * mz)',
              f'bz = tz - ({p} * my - {q} * mx)',
              f'{name}0 = 0.5 * (-{x} * {p} - {yy} * {q} - {z} * {r})',
              f'{name}1 = 0.5 * ({w} * {p} + {yy} * {r} - {z} * {q})',
              f'{name}2 = 0.5 * ({w} * {q} - {x} * {r} + {z} * {p})',
              f'{name}3 = 0.5 * ({w} * {r} + {x} * {q} - {yy} * {p})']
    if diagonal:
        lines += [f'{name}4 = i00 * bx', f'{name}5 = i11 * by', f'{name}6 = i22 * bz']
    else:
        lines += [f'{name}4 = i00 * bx + i01 * by + i02 * bz',
                  f'{name}5 = i10 * bx + i11 * by + i12 * bz',
                  f'{name}6 = i20 * bx + i21 * by + i22 * bz']
    lines.append(f'{name}7 = {p} * tx + {q} * ty + {r} * tz' if torque or rotor
                 else f'{name}7 = 0.0')
    return lines


#: Names the step reads, bound as default arguments (local variables: the fastest lookup).
_CONSTANTS = ('j00', 'j01', 'j02', 'j10', 'j11', 'j12', 'j20', 'j21', 'j22',
              'i00', 'i01', 'i02', 'i10', 'i11', 'i12', 'i20', 'i21', 'i22')


def _source(diagonal: bool, torque: bool, rotor: bool) -> str:
    """The step's source for one combination of the model's terms."""
    y = [f'y{i}' for i in range(7)]
    bound = _CONSTANTS + (('torque',) if torque else ()) + (('rotor',) if rotor else ())
    lines = [f'def step(t, y, h, {", ".join(f"{n}={n}" for n in bound)}):',
             '    y0, y1, y2, y3, y4, y5, y6 = y', '    half = 0.5 * h']
    body: list[str] = []
    previous = ''
    for name, time, scale in (('a', 't', ''), ('b', 't + half', 'half'),
                              ('c', 't + half', 'half'), ('d', 't + h', 'h')):
        if previous:
            body += [f'z{i} = y{i} + {scale} * {previous}{i}' for i in range(7)]
            body += _stage(name, time, [f'z{i}' for i in range(7)], diagonal, torque, rotor)
        else:
            body += _stage(name, time, y, diagonal, torque, rotor)
        previous = name
    body.append('s = h / 6.0')
    body.append('return ((' + ', '.join(
        f'y{i} + s * (a{i} + 2.0 * (b{i} + c{i}) + d{i})' for i in range(7))
        + '), s * (a7 + 2.0 * (b7 + c7) + d7))')
    return '\n'.join(lines + ['    ' + line for line in body]) + '\n'


def rk4_kernel(model: BodyModel) -> Rk4Kernel:
    """The RK4 step specialised for ``model`` (torque and rotor called as plain floats).

    Models that do not take plain-float torques get the generic step of
    :func:`rk4_work_step`.
    """
    tensor, inverse = model.tensor_entries, model.inverse_entries
    diagonal = all(tensor[i] == 0.0 for i in (1, 2, 3, 5, 6, 7)) and all(
        inverse[i] == 0.0 for i in (1, 2, 3, 5, 6, 7))
    torque = model.has_torque
    rotor = model.has_rotor
    if (torque or rotor) and not model.torque_takes_floats:
        def generic(t: float, y: tuple[float, ...], h: float) -> tuple[tuple[float, ...], float]:
            return rk4_work_step(model, t, y, h)
        return generic
    key = (diagonal, torque, rotor, tensor, inverse)
    compiled = _CACHE.get(key) if not (torque or rotor) else None
    if compiled is not None:
        return compiled
    namespace: dict[str, object] = dict(zip(
        ('j00', 'j01', 'j02', 'j10', 'j11', 'j12', 'j20', 'j21', 'j22'), tensor))
    namespace.update(zip(('i00', 'i01', 'i02', 'i10', 'i11', 'i12', 'i20', 'i21', 'i22'),
                         inverse))
    if torque:
        namespace['torque'] = model.torque_body
    if rotor:
        namespace['rotor'] = model.rotor_momentum
    exec(compile(_source(diagonal, torque, rotor), '<rk4_kernel>', 'exec'), namespace)
    kernel: Rk4Kernel = namespace['step']  # type: ignore[assignment]
    if not (torque or rotor):
        _CACHE[key] = kernel
    return kernel


def rk4_work_step(model: BodyModel, t: float, state: tuple[float, ...],
                  h: float) -> tuple[tuple[float, ...], float]:
    """One classical RK4 step of ``h`` from ``t`` on the 7-float state ``(q, ω)``, without
    renormalisation, and the work [J] of the torques over the step (RK4 quadrature of the
    stage powers). Plain floats, every stage written out (no per-stage tuple building)."""
    y0, y1, y2, y3, y4, y5, y6 = state
    half = 0.5 * h
    a0, a1, a2, a3, a4, a5, a6, a7 = body_derivative_power(model, t, state)
    b0, b1, b2, b3, b4, b5, b6, b7 = body_derivative_power(model, t + half, (
        y0 + half * a0, y1 + half * a1, y2 + half * a2, y3 + half * a3, y4 + half * a4,
        y5 + half * a5, y6 + half * a6))
    c0, c1, c2, c3, c4, c5, c6, c7 = body_derivative_power(model, t + half, (
        y0 + half * b0, y1 + half * b1, y2 + half * b2, y3 + half * b3, y4 + half * b4,
        y5 + half * b5, y6 + half * b6))
    d0, d1, d2, d3, d4, d5, d6, d7 = body_derivative_power(model, t + h, (
        y0 + h * c0, y1 + h * c1, y2 + h * c2, y3 + h * c3, y4 + h * c4, y5 + h * c5,
        y6 + h * c6))
    s = h / 6.0
    return ((y0 + s * (a0 + 2.0 * (b0 + c0) + d0), y1 + s * (a1 + 2.0 * (b1 + c1) + d1),
             y2 + s * (a2 + 2.0 * (b2 + c2) + d2), y3 + s * (a3 + 2.0 * (b3 + c3) + d3),
             y4 + s * (a4 + 2.0 * (b4 + c4) + d4), y5 + s * (a5 + 2.0 * (b5 + c5) + d5),
             y6 + s * (a6 + 2.0 * (b6 + c6) + d6)),
            s * (a7 + 2.0 * (b7 + c7) + d7))


def rk4_state_step(model: BodyModel, t: float, state: tuple[float, ...],
                   h: float) -> tuple[float, ...]:
    """:func:`rk4_work_step` without the work."""
    return rk4_work_step(model, t, state, h)[0]
