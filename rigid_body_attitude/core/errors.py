"""Exception types of rigid_body_attitude.

Every error raised for a user's mistake is one of these. They derive from ``ValueError`` so
callers that only know the standard library still catch them. Messages name the bad value and
what was expected (``Expected `inertia` to be symmetric, got ...``).
"""

from __future__ import annotations

__all__ = [
    'AttitudeError',
    'CalibrationError',
    'InertiaError',
    'InputError',
    'IntegratorError',
    'SceneError',
]


class AttitudeError(ValueError):
    """Base class of every error this package raises for bad input."""


class InputError(AttitudeError):
    """A numeric argument has the wrong shape, is not finite, or is out of range."""


class InertiaError(AttitudeError):
    """An inertia tensor is not symmetric, not positive definite, or violates J1 + J2 >= J3."""


class SceneError(AttitudeError):
    """A scene file or dictionary is malformed: unknown names, wrong types, missing keys."""


class IntegratorError(AttitudeError):
    """An integrator was asked for something it cannot do (unknown name, unstable step)."""


class CalibrationError(AttitudeError):
    """An IMU calibration file is malformed: missing keys, wrong shapes, singular matrices."""
