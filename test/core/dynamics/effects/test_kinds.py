"""Effect kinds: every registered effect says what it provides by its base classes.

Issue 12 item 3: no capability is found by ``hasattr``; the propagator sorts effects by kind.
Each effect lives in its own module whose docstring gives the equation and a source.
"""

from __future__ import annotations

import inspect

import pytest

from rigid_body_attitude.core.dynamics.effects import (
    EFFECTS, ForceEffect, RateCorrection, RotorEffect, StatefulEffect, TorqueEffect)
from rigid_body_attitude.core.errors import IntegratorError, SceneError
from rigid_body_attitude.core.dynamics.integrators import DYNAMICS_INTEGRATORS, dynamics_integrator
from rigid_body_attitude.core.registry import Registry

KINDS = (TorqueEffect, RotorEffect, ForceEffect, RateCorrection, StatefulEffect)


@pytest.mark.parametrize('name', sorted(EFFECTS))
def test_every_effect_declares_a_kind_in_its_own_documented_module(name):
    cls = EFFECTS[name]
    assert any(issubclass(cls, kind) for kind in KINDS), name
    assert not inspect.isabstract(cls), name
    module = inspect.getmodule(cls)
    assert module.__name__.endswith('.' + name)
    assert 'Source' in module.__doc__, name
    assert [c for c in vars(module).values()
            if inspect.isclass(c) and c.__module__ == module.__name__
            and issubclass(c, KINDS)] == [cls]


def test_one_registry_mechanism_for_effects_and_integrators():
    assert isinstance(EFFECTS, Registry) and isinstance(DYNAMICS_INTEGRATORS, Registry)
    with pytest.raises(SceneError, match="registered twice"):
        EFFECTS.register(EFFECTS['viscous_damping'])
    with pytest.raises(IntegratorError, match=r"Unknown dynamics integrator 'rk5'; expected one "
                       r"of casimir6, casimir8, dopri45, exact, rk4"):
        dynamics_integrator('rk5')


def test_an_effect_missing_its_kind_method_cannot_be_built():
    class Incomplete(TorqueEffect):
        name = 'incomplete'

    assert inspect.isabstract(Incomplete)
    with pytest.raises(TypeError, match='abstract'):
        Incomplete({}, None)
