"""The sample-and-hold grid of a controller effect is the one ``attitude_controller`` uses:
a sample at the start, then at every whole multiple ``n T`` of the control period (a start
off the grid included), so the two recompute at the same instants."""

from __future__ import annotations

import math

import pytest

from rigid_body_attitude.core.dynamics.effects import EFFECTS
from rigid_body_attitude.core.dynamics.effects.base import BodyProperties
from rigid_body_attitude.core.dynamics.inertia import Inertia

BODY = BodyProperties(Inertia([0.5, 0.7, 0.9]), 2.0)
STATE = ((math.cos(0.3), math.sin(0.3), 0.0, 0.0), (0.1, 0.0, 0.0))


def effect():
    return EFFECTS['attitude_pd']({'kp': 1.0, 'kd': 2.0, 'control_period': 0.1}, BODY)


@pytest.mark.parametrize('start, instants', [
    (0.0, [0.1, 0.2, 0.30000000000000004]),  # n T in floating point
    (0.05, [0.1, 0.2, 0.30000000000000004]),  # off the grid: the next multiple, not 0.15
    (0.3, [0.4, 0.5, 0.6000000000000001]),  # 0.3 / 0.1 = 2.9999999999999996: still n = 3
    (1.7e9 + 0.05, [1.7e9 + 0.1, 1.7e9 + 0.2, 1.7e9 + 0.30000000000000004]),
])
def test_samples_at_the_start_then_at_whole_multiples_of_the_period(start, instants):
    controller = effect()
    assert controller.due(start)
    controller.sample(start, *STATE)
    assert not controller.due(start)
    seen = []
    for _ in instants:
        seen.append(controller.next_sample())
        controller.sample(seen[-1], *STATE)
    assert seen == pytest.approx(instants, rel=1e-15, abs=0.0)
    controller.reset()
    assert controller.due(start + 0.01)  # a reset: the next advance samples first
