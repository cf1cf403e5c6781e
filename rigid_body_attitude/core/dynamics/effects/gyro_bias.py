"""gyro_bias: subtract a constant gyro bias, given or estimated at rest.

``ω = ω_measured − b``. With ``estimate_seconds: N > 0`` the body must be at rest for the
first ``N`` seconds of samples: during that window the samples are averaged into ``b`` (plus
the given ``bias`` as a prior offset of zero weight) and the corrected rate is zero, so the
attitude holds still; afterwards ``b`` is the mean. Assumption: a constant bias over the run
(no temperature drift); Earth rate, when also named, should come after this effect. Source:
the constant-bias term of the usual gyro error model (Titterton & Weston, *Strapdown Inertial
Navigation Technology*, gyro errors).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.dynamics.effects.base import (
    BodyProperties, RateCorrection, Parameter, nonnegative, register, vector3)


@register
class GyroBias(RateCorrection):
    """Constant gyro bias [rad/s], fixed or estimated from an initial rest phase."""

    name = 'gyro_bias'
    description = 'subtract a constant gyro bias, given or estimated at rest'
    parameters = {
        'bias': Parameter(vector3, [0.0, 0.0, 0.0], 'bias [rad/s], body axes'),
        'estimate_seconds': Parameter(nonnegative, 0.0,
                                      'average the first N seconds at rest (0 = off) [s]'),
    }

    def __init__(self, params: dict[str, Any], body: BodyProperties) -> None:
        """Start with the given bias, or an empty estimate."""
        super().__init__(params, body)
        self.reset()

    def reset(self) -> None:
        """Restart the estimate (or return to the given bias)."""
        self.bias = np.array(self.params['bias'])
        self.estimating = self.params['estimate_seconds'] > 0.0
        self.start_time: float | None = None
        self.sample_sum = np.zeros(3)
        self.sample_count = 0

    def corrected_rate(self, t: float, attitude: NDArray[Any],
                       omega_measured: NDArray[Any]) -> NDArray[Any]:
        """``ω_measured − b``; zero while the rest-phase estimate is being collected."""
        if self.estimating:
            if self.start_time is None:
                self.start_time = t
            if t - self.start_time < self.params['estimate_seconds']:
                self.sample_sum += omega_measured
                self.sample_count += 1
                return np.zeros(3)
            self.estimating = False
            if self.sample_count:
                self.bias = self.sample_sum / self.sample_count
        corrected: NDArray[Any] = omega_measured - self.bias
        return corrected
