"""Inertia tensors: validation, shapes and principal axes.

An :class:`Inertia` holds a symmetric positive-definite tensor ``J`` [kg m²] in body axes,
about the centre of mass (or about the fixed point for a body on a pivot). It is checked once,
at construction: symmetric (to a relative 1e−12), finite, positive definite and satisfying the
triangle inequalities of the principal moments (``J₁ + J₂ ≥ J₃`` for every permutation, which
holds for any real mass distribution). Errors name the offending values.

Shapes: the inertia tensor and the parallel-axis theorem of Landau & Lifshitz, *Mechanics*, 3rd
ed., 1976, §32.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.errors import InertiaError

__all__ = ['Inertia']

FloatArray = NDArray[np.float64]

_SYMMETRY_TOLERANCE = 1e-12
_TRIANGLE_TOLERANCE = 1e-12
#: Smallest accepted ratio J_min/J_max. ``eigh`` finds the eigenvalues of a symmetric matrix
#: to an absolute error of a few ε·J_max, so below this the smallest moment (and the sign
#: that makes the tensor positive definite) is rounding noise: the tensor is numerically
#: singular and ``J⁻¹`` would be noise or overflow.
_SINGULARITY_RATIO = 64.0 * float(np.finfo(np.float64).eps)


def _validated_tensor(value: ArrayLike) -> FloatArray:
    try:
        tensor = np.array(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InertiaError(f'Expected `inertia` to be a 3×3 matrix or 3 principal moments, '
                           f'got {value!r}') from err
    if tensor.shape == (3,):
        tensor = np.diag(tensor)
    if tensor.shape != (3, 3):
        raise InertiaError(f'Expected `inertia` to be a 3×3 matrix or 3 principal moments, '
                           f'got shape {tensor.shape}: {tensor.tolist()!r}')
    if not np.all(np.isfinite(tensor)):
        raise InertiaError(f'Expected `inertia` to be finite, got {tensor.tolist()!r}')
    scale = float(np.max(np.abs(tensor)))
    asymmetry = float(np.max(np.abs(tensor - tensor.T)))
    if asymmetry > _SYMMETRY_TOLERANCE * max(scale, 1e-300):
        raise InertiaError(f'Expected `inertia` to be symmetric, got {tensor.tolist()!r} '
                           f'(largest |J - Jᵀ| = {asymmetry:.3g})')
    # Symmetric input is returned unchanged (no halving of subnormals, no overflow of J + Jᵀ).
    return tensor + 0.5 * (tensor.T - tensor)


def _validated_moments(tensor: FloatArray,
                       triangle: bool = True) -> tuple[FloatArray, FloatArray]:
    moments, axes = np.linalg.eigh(tensor)
    if not np.all(np.isfinite(moments)):
        raise InertiaError(f'Expected `inertia` with finite principal moments, got '
                           f'{tensor.tolist()!r} with principal moments {moments.tolist()!r}')
    if moments[0] <= 0.0:
        raise InertiaError(f'Expected `inertia` to be positive definite, got {tensor.tolist()!r} '
                           f'with principal moments {moments.tolist()!r}')
    if moments[0] <= _SINGULARITY_RATIO * moments[2]:
        raise InertiaError(f'Expected `inertia` to be numerically non-singular (smallest/largest '
                           f'principal moment > {_SINGULARITY_RATIO:.3g}), got '
                           f'{tensor.tolist()!r} with principal moments {moments.tolist()!r}')
    slack = moments[0] + moments[1] - moments[2]
    if triangle and slack < -_TRIANGLE_TOLERANCE * moments[2]:
        raise InertiaError(f'Expected principal moments with J1 + J2 >= J3 (a real mass '
                           f'distribution), got {moments.tolist()!r}')
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]
    return moments, axes


@dataclass(frozen=True)
class Inertia:
    """A validated inertia tensor ``J`` [kg m²] in body axes.

    Attributes:
        tensor: the symmetric positive-definite 3×3 matrix.
        principal_moments: eigenvalues of ``tensor`` in ascending order.
        principal_axes: right-handed rotation matrix whose columns are the principal axes in
            body coordinates (``tensor = axes @ diag(moments) @ axes.T``).
        inverse: ``tensor⁻¹``.
    """

    tensor: FloatArray
    principal_moments: FloatArray = field(init=False, repr=False)
    principal_axes: FloatArray = field(init=False, repr=False)
    inverse: FloatArray = field(init=False, repr=False)

    def __init__(self, tensor: ArrayLike, triangle: bool = True) -> None:
        """Validate ``tensor`` (3×3, or 3 principal moments) and precompute its decomposition.

        ``triangle=False`` drops the triangle inequalities: for the inertia a body keeps
        around spinning rotors (``J − Σ Jₛ â âᵀ``), which is no rigid body's.
        """
        checked = _validated_tensor(tensor)
        moments, axes = _validated_moments(checked, triangle)
        object.__setattr__(self, 'tensor', checked)
        object.__setattr__(self, 'principal_moments', moments)
        object.__setattr__(self, 'principal_axes', axes)
        inverse = np.linalg.inv(checked)
        if not np.all(np.isfinite(inverse)):
            raise InertiaError(f'Expected `inertia` with a finite inverse, got '
                               f'{checked.tolist()!r} (inverse {inverse.tolist()!r})')
        object.__setattr__(self, 'inverse', inverse)

    @property
    def is_diagonal(self) -> bool:
        """True when the body axes are principal axes (all products of inertia are zero)."""
        off_diagonal = self.tensor - np.diag(np.diag(self.tensor))
        return bool(np.all(off_diagonal == 0.0))

    @property
    def principal_rotation(self) -> FloatArray:
        """Quaternion taking principal-axis coordinates to body coordinates."""
        return quaternion.from_matrix(self.principal_axes)

    @classmethod
    def box(cls, mass: float, edges: ArrayLike, about: str = 'centre') -> Inertia:
        """Solid box of ``mass`` [kg] and ``edges`` (a, b, c) [m] along x, y, z.

        ``about='centre'``: diag(M(b²+c²), M(c²+a²), M(a²+b²))/12.
        ``about='corner'``: about a corner with the edges on the positive axes (the centre
        values moved by the parallel-axis theorem): diagonal M(b²+c²)/3 …, products of inertia
        −M ab/4, −M ac/4, −M bc/4.
        """
        mass = _positive(mass, 'mass')
        a, b, c = _positive_vector(edges, 'edges')
        if about == 'centre':
            return cls(mass / 12.0 * np.array([b * b + c * c, c * c + a * a, a * a + b * b]))
        if about == 'corner':
            return cls(mass * np.array([
                [(b * b + c * c) / 3.0, -a * b / 4.0, -a * c / 4.0],
                [-a * b / 4.0, (c * c + a * a) / 3.0, -b * c / 4.0],
                [-a * c / 4.0, -b * c / 4.0, (a * a + b * b) / 3.0],
            ]))
        raise InertiaError(f"Expected `about` to be 'centre' or 'corner', got {about!r}")

    @classmethod
    def cylinder(cls, mass: float, radius: float, height: float) -> Inertia:
        """Solid cylinder, axis along body z, about its centre.

        ``J_z = M r²/2``, ``J_x = J_y = M (3r² + h²)/12``.
        """
        mass = _positive(mass, 'mass')
        radius = _positive(radius, 'radius')
        height = _positive(height, 'height')
        transverse = mass * (3.0 * radius * radius + height * height) / 12.0
        return cls([transverse, transverse, 0.5 * mass * radius * radius])

    @classmethod
    def sphere(cls, mass: float, radius: float) -> Inertia:
        """Solid sphere about its centre: ``J = (2/5) M r² I``."""
        mass = _positive(mass, 'mass')
        radius = _positive(radius, 'radius')
        return cls([0.4 * mass * radius * radius] * 3)


def _positive(value: float, name: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError) as err:
        raise InertiaError(f'Expected `{name}` to be a positive number, got {value!r}') from err
    if not np.isfinite(number) or number <= 0.0:
        raise InertiaError(f'Expected `{name}` to be a positive number, got {value!r}')
    return number


def _positive_vector(value: ArrayLike, name: str) -> FloatArray:
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise InertiaError(f'Expected `{name}` to be 3 positive numbers, got {value!r}') from err
    if array.shape != (3,) or not np.all(np.isfinite(array)) or np.any(array <= 0.0):
        raise InertiaError(f'Expected `{name}` to be 3 positive numbers, got {value!r}')
    return array
