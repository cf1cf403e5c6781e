"""bdot: the B-dot detumbling law in the loop, sampled and held, driving the magnetorquers.

Every ``control_period`` seconds (a whole number of the scene's steps) the controller reads the
field in body axes, ``B_b = R(q)ᵀ B_w(t)`` (an ideal magnetometer: the scene's field model),
and holds the dipole ``m = −k (B_b − B_b,prev) / T`` [A m²] (zero at the first sample) until the
next sample; the scene's ``magnetorquers`` give it within their rods' limits
(Source: A. C. Stickler and K. T. Alfriend, "Elementary magnetic attitude control system",
Journal of Spacecraft and Rockets 13(5):282-287, 1976; Markley and Crassidis, *Fundamentals of
Spacecraft Attitude Determination and Control*, 2014, sec. 7.5; the law in
:mod:`rigid_body_attitude.core.control.magnetic`). It damps the rate across the field; the
rate along the field is damped only as the field turns along the orbit (about twice per
orbit), so detumbling takes of the order of an orbit. ``gain`` ``k`` [A m² s/T]; Avanzini
and Giulietti's choice ``k = 2 n (1 + sin ξ) J_min`` / ``|B|²``-scale is a starting point.
The same law runs in the batch engine (every body with its own previous sample and, when
dispersed, its own gain).
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.control.magnetic import bdot_dipole, bdot_dipole_rows
from rigid_body_attitude.core.dynamics.effects.base import (
    BatchChunk, BodyProperties, FloatArray, nonnegative, Parameter, positive, Quat, register,
    REQUIRED, Vec)
from rigid_body_attitude.core.dynamics.effects.sampled import SampledTorque


@register
class Bdot(SampledTorque):
    """B-dot: a held dipole [A m², body] for the magnetorquers, sampled every period."""

    name = 'bdot'
    description = 'B-dot detumbling: m = -k dB/dt, sampled every control_period, held'
    parameters = {
        'gain': Parameter(nonnegative, REQUIRED, 'k [A m² s/T]'),
        'control_period': Parameter(positive, REQUIRED,
                                    'sample period [s], a whole number of steps'),
    }
    requires = ('magnetorquers',)
    shared_parameters: ClassVar[frozenset[str]] = frozenset({'control_period'})
    #: Batch rows: the held dipole (3), ∫|m| dt, the peak |m|, the previous field (3).
    STATE_ROWS: ClassVar[int] = 8

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Check the scene's field; drive the magnetorquers."""
        super().__init__(params, body)
        self.model = body.environment.required_field(self.name)
        self.actuator = 'magnetorquers'
        self.applies_torque = False

    def reset(self) -> None:
        """No previous field sample."""
        super().reset()
        self.previous: Vec | None = None

    @property
    def period(self) -> float:
        """``control_period`` [s]."""
        return float(self.params['control_period'])

    def control(self, t: float, q: Quat, omega: Vec) -> Vec:
        """The dipole from this field sample and the previous one."""
        field = quaternion.rotate_inverse_floats(q, self.model.field_world(t))
        dipole = bdot_dipole(field, self.previous, self.period, self.params['gain'])
        self.previous = field
        return dipole

    def control_batch(self, t: float, q: FloatArray, omega: FloatArray, chunk: BatchChunk,
                      out: FloatArray) -> None:
        """The law on every body (its previous sample in its state rows)."""
        field = quaternion.rotate_rows(q, np.array(self.model.field_world(t))[:, None],
                                       inverse=True)
        previous = chunk.state[5:8]
        if self.origin is None:
            out[:] = 0.0
        else:
            bdot_dipole_rows(field, previous, self.period, chunk.parameters['gain'], out)
        previous[:] = field
