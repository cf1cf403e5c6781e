"""Effects a scene may name; each module registers one effect class in :data:`EFFECTS`.

Importing this package imports every module in it, so a new effect module is found without
editing any other file.
"""

from __future__ import annotations

import importlib
import pkgutil

from rigid_body_attitude.core.dynamics.effects.base import (
    BatchChunk, BodyProperties, CommandedEffect, ConservativeTorque, Effect, EFFECTS, Environment,
    ForceEffect, RateCorrection, RotorEffect, StatefulEffect, TorqueEffect)
from rigid_body_attitude.core.dynamics.effects.held import HeldOverStep, RotorState
from rigid_body_attitude.core.dynamics.effects.sampled import SampledTorque

__all__ = ['BatchChunk', 'BodyProperties', 'CommandedEffect', 'ConservativeTorque', 'EFFECTS',
           'Effect', 'Environment', 'ForceEffect', 'HeldOverStep', 'RateCorrection',
           'RotorEffect', 'RotorState', 'SampledTorque', 'StatefulEffect', 'TorqueEffect']

for _module in pkgutil.iter_modules(__path__):
    if _module.name not in ('base', 'held', 'sampled'):
        importlib.import_module(f'{__name__}.{_module.name}')
