"""Campaign specs: a scene, runs, times and dispersions, read from YAML and validated once.

Format (``config/campaigns/`` ships examples)::

    name: gg_pointing                # default: the file's stem
    description: ...
    scene: gravity_gradient_satellite  # a built-in scene name, a scene file (relative to the
                                       # spec's folder), or a scene mapping inline
    runs: 1000
    seed: 2026                       # root of numpy.random.SeedSequence; per-run streams
    duration: 600.0                  # [s]
    output_times: {every: 60.0}      # or a list of times in (0, duration]; duration is added
    chunk: 8192                      # runs per task (default 8192)
    dispersions:
      inertia: {second_moments_sigma: 0.05, axes: {cone_deg: 1.0}}
        # or axes: uniform; or {tensor_sigma: 0.02} (a perturbed tensor, made physical)
      attitude: uniform              # or {cone_deg: 5.0} about the scene's attitude
      omega_body: {sigma: [1.0e-4, 1.0e-4, 1.0e-4]}   # [rad/s], or {half_range: [...]}
      effects: {gravity_gradient: {orbit_radius: {relative_sigma: 1.0e-3}}}
        # a spread is {sigma: s} (normal, absolute), {relative_sigma: s} or {uniform: [lo, hi]}
      commands: {sigma: [1.0e-3, 1.0e-3, 1.0e-3]}     # [N m] added to every command per run
    commands:                        # body-frame torques, each held until the next
      - {time: 0.0, torque: [0.0, 0.0, 1.0e-3]}
    statistics:
      percentiles: [5, 50, 95]
      boresight: [0, 0, 1]           # body axis for pointing and nutation
      target: [0, 0, 1]              # world direction (default: boresight at the start, or
                                     # at the attitude_pd controller's target)
      settling_deg: 1.0              # closed loop: settled once the pointing error stays below
      nutation_min_rate: 1.0e-4      # [rad/s] slower runs have no nutation (statistics.py)

Errors are one :class:`SpecError` naming the file and the key path
(``dispersions.attitude.cone_deg``), as for scene files
(:mod:`rigid_body_attitude.core.dynamics.scene`:
same size, UTF-8, alias and nesting limits).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.effects.attitude_pd import AttitudePD
from rigid_body_attitude.core.errors import AttitudeError, SceneError
from rigid_body_attitude.core.dynamics.scene import load_scene, Scene, scene_from_mapping
from rigid_body_attitude.core.yaml_files import Fields, quote, read_yaml
from rigid_body_attitude.tools.campaign.budget import budget_problem
from rigid_body_attitude.tools.campaign.statistics import NUTATION_MIN_RATE

__all__ = ['CampaignSpec', 'CommandDispersion', 'InertiaDispersion', 'MAX_OUTPUT_TIMES',
           'MAX_RUNS', 'Spread', 'SpecError', 'load_spec', 'spec_from_mapping']

FloatArray = NDArray[np.float64]

#: Most runs and output times of one campaign.
MAX_RUNS = 10 ** 9
MAX_OUTPUT_TIMES = 10_000
MAX_COMMANDS = 1000
DEFAULT_CHUNK = 8192
COMMAND_EFFECT = 'constant_torque'
CONTROLLER_EFFECT = AttitudePD.name
_TOP_KEYS = {'name', 'description', 'scene', 'runs', 'seed', 'duration', 'output_times',
             'chunk', 'dispersions', 'commands', 'statistics'}
_DISPERSION_KEYS = {'inertia', 'attitude', 'omega_body', 'effects', 'commands'}
_STATISTICS_KEYS = {'percentiles', 'boresight', 'target', 'settling_deg', 'nutation_min_rate'}


class SpecError(SceneError):
    """A campaign spec is malformed (the message names the key)."""


_FIELDS = Fields(SpecError)


@dataclass(frozen=True)
class Spread:
    """A dispersion of one number or vector: ``kind`` is ``sigma`` (normal, absolute),
    ``relative_sigma`` (normal, times the nominal) or ``uniform`` (``low``..``high``)."""

    kind: str
    sigma: FloatArray = field(default_factory=lambda: np.zeros(1))
    low: FloatArray = field(default_factory=lambda: np.zeros(1))
    high: FloatArray = field(default_factory=lambda: np.zeros(1))


@dataclass(frozen=True)
class InertiaDispersion:
    """Inertia: second moments scaled log-normally (``second_moments_sigma``) with axes
    ``uniform`` or within ``axes_cone`` [rad] of the nominal; or ``tensor_sigma``."""

    second_moments_sigma: float = 0.0
    axes: str = 'nominal'
    axes_cone: float = 0.0
    tensor_sigma: float = 0.0


@dataclass(frozen=True)
class CommandDispersion:
    """Per-run error added to every commanded torque: normal, ``sigma`` [N m] per axis."""

    sigma: FloatArray


@dataclass(frozen=True)
class CampaignSpec:
    """A validated campaign (see the module's format)."""

    name: str
    description: str
    scene: Scene
    runs: int
    seed: int
    duration: float
    output_times: tuple[float, ...]
    chunk: int = DEFAULT_CHUNK
    inertia: InertiaDispersion | None = None
    attitude: str = 'nominal'
    attitude_cone: float = 0.0
    omega_body: Spread | None = None
    effects: Mapping[str, Mapping[str, Spread]] = field(default_factory=dict)
    commands: tuple[tuple[float, FloatArray], ...] = ()
    command_dispersion: CommandDispersion | None = None
    percentiles: tuple[float, ...] = (5.0, 50.0, 95.0)
    boresight: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    target: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    source: str = ''
    settling_deg: float = 1.0
    nutation_min_rate: float = NUTATION_MIN_RATE

    @property
    def closed_loop(self) -> bool:
        """Whether the scene runs an attitude controller (settling and torque recorded)."""
        return any(name == CONTROLLER_EFFECT for name, _ in self.scene.effects)


def load_spec(path: str | Path) -> CampaignSpec:
    """Load and validate a campaign spec file; every fault is one :class:`SpecError` whose
    text starts ``Campaign file '<path>'``."""
    path = Path(path).expanduser()
    where = f'Campaign file {str(path)!r}'
    data = read_yaml(path, where, SpecError, 'campaign files')
    try:
        return spec_from_mapping(data, default_name=path.stem, base=path.parent,
                                 source=str(path))
    except SpecError as err:
        raise SpecError(f'{where}: {err}') from None
    except SceneError as err:
        text = str(err)
        raise SpecError(text if text.startswith(where) else f'{where}: {text}') from None


def spec_from_mapping(data: Any, default_name: str = 'campaign', base: Path | None = None,
                      source: str = '') -> CampaignSpec:
    """Validate a campaign given as a mapping (the parsed YAML); scene files are looked for
    relative to ``base``."""
    if not isinstance(data, Mapping):
        raise SpecError(f'Expected a campaign to be a mapping with keys '
                        f'{", ".join(sorted(_TOP_KEYS))}, got {quote(data)}')
    _FIELDS.keys(data, _TOP_KEYS, 'campaign', ('scene', 'runs', 'duration'))
    scene = _scene(data['scene'], base)
    duration = _positive('duration', data['duration'])
    commands = _commands(data.get('commands', []), duration)
    if commands:
        scene = _with_command_effect(scene)
    dispersions = _mapping('dispersions', data.get('dispersions'), _DISPERSION_KEYS)
    attitude, cone = _attitude(dispersions.get('attitude', 'nominal'))
    statistics = _mapping('statistics', data.get('statistics'), _STATISTICS_KEYS)
    boresight = _direction('statistics.boresight', statistics.get('boresight', [0, 0, 1]))
    default_target = quaternion.rotate(_controller_target(scene), boresight)
    spec = CampaignSpec(
        name=_text('name', data.get('name', default_name)),
        description=_text('description', data.get('description', '')),
        scene=scene, runs=_count('runs', data['runs'], MAX_RUNS),
        seed=_seed(data.get('seed', 0)), duration=duration,
        output_times=_output_times(data.get('output_times', [duration]), duration),
        chunk=_count('chunk', data.get('chunk', DEFAULT_CHUNK), 10 ** 7),
        inertia=_inertia(dispersions.get('inertia')), attitude=attitude, attitude_cone=cone,
        omega_body=_optional_spread('dispersions.omega_body', dispersions.get('omega_body'),
                                    3, ('sigma', 'half_range')),
        effects=_effects(dispersions.get('effects', {}), scene, bool(commands)),
        commands=commands,
        command_dispersion=_command_dispersion(dispersions.get('commands'), commands),
        percentiles=_percentiles(statistics.get('percentiles', [5, 50, 95])),
        boresight=boresight,
        target=_direction('statistics.target', statistics.get('target',
                                                              default_target.tolist())),
        source=source, settling_deg=_settling(statistics, scene),
        nutation_min_rate=_nonnegative('statistics.nutation_min_rate', statistics.get(
            'nutation_min_rate', NUTATION_MIN_RATE)))
    problem = budget_problem(spec)
    if problem:
        raise SpecError(problem)
    return spec


def _mapping(key: str, value: Any, valid: set[str] | None = None,
             required: tuple[str, ...] = ()) -> Mapping[Any, Any]:
    """A mapping (``None``: empty) with keys among ``valid`` and the ``required`` ones."""
    return _FIELDS.mapping(value, key, valid, required, none_is_empty=True)


def _text(key: str, value: Any) -> str:
    if not isinstance(value, str) or len(value) > 1024:
        raise SpecError(f'Expected {key} to be text of at most 1024 characters, got '
                        f'{quote(value)}')
    return value


def _positive(key: str, value: Any) -> float:
    return _FIELDS.number(value, key, 0.0, low_open=True)


def _nonnegative(key: str, value: Any) -> float:
    return _FIELDS.number(value, key, 0.0)


def _count(key: str, value: Any, limit: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= limit:
        raise SpecError(f'Expected {key} to be a whole number from 1 to {limit}, got '
                        f'{quote(value)}')
    return value


def _seed(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 2 ** 128:
        raise SpecError(f'Expected seed to be a whole number from 0 to 2^128 - 1, got '
                        f'{quote(value)}')
    return value


def _vector(key: str, value: Any, size: int = 3) -> FloatArray:
    """``size`` numbers, or one number for all (``sigma: 0.1``)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = [value] * size
    return np.array(_FIELDS.vector(value, key, size))


def _direction(key: str, value: Any) -> FloatArray:
    vector = _vector(key, value)
    length = float(np.linalg.norm(vector))
    if not length > 1e-12:
        raise SpecError(f'Expected {key} to be a non-zero direction, got {quote(value)}')
    result: FloatArray = vector / length
    return result


def _scene(value: Any, base: Path | None) -> Scene:
    try:
        if isinstance(value, Mapping):
            return scene_from_mapping(value, default_name='scene')
        if not isinstance(value, str):
            raise SpecError(f'Expected scene to be a scene name, a file or a mapping, got '
                            f'{quote(value)}')
        relative = base / value if base is not None else None
        return load_scene(str(relative) if relative is not None and relative.is_file()
                          else value)
    except SpecError:
        raise
    except SceneError as err:
        raise SpecError(f'scene: {err}') from None


def _with_command_effect(scene: Scene) -> Scene:
    """The scene with a body-frame ``constant_torque`` whose torque the commands set."""
    if scene.rate_source != 'dynamics':
        raise SpecError(f'commands: scene {scene.name!r} is not a dynamics scene')
    if any(name == COMMAND_EFFECT for name, _ in scene.effects):
        raise SpecError(f'commands: scene {scene.name!r} already names {COMMAND_EFFECT}, '
                        f'which carries the commands')
    added = dataclasses.replace(scene, effects=scene.effects + (
        (COMMAND_EFFECT, {'torque': [0.0, 0.0, 0.0], 'frame': 'body'}),))
    try:
        return added.with_overrides()
    except AttitudeError as err:
        raise SpecError(f'commands: {err}') from None


def _commands(value: Any, duration: float) -> tuple[tuple[float, FloatArray], ...]:
    if not isinstance(value, list) or len(value) > MAX_COMMANDS:
        raise SpecError(f'Expected commands to be a list of at most {MAX_COMMANDS} '
                        f'{{time, torque}}, got {quote(value)}')
    commands: list[tuple[float, FloatArray]] = []
    for index, item in enumerate(value):
        key = f'commands[{index}]'
        item = _mapping(key, item, {'time', 'torque'}, ('time', 'torque'))
        time = _nonnegative(f'{key}.time', item['time'])
        if time >= duration or (commands and time <= commands[-1][0]):
            raise SpecError(f'Expected {key}.time to increase and be below duration, got '
                            f'{quote(item["time"])}')
        commands.append((time, _vector(f'{key}.torque', item['torque'])))
    return tuple(commands)


def _output_times(value: Any, duration: float) -> tuple[float, ...]:
    if isinstance(value, Mapping):
        _FIELDS.keys(value, {'every'}, 'output_times', ('every',))
        every = _positive('output_times.every', value['every'])
        ratio = duration / every  # at most 1e75 / 1e-308: inf, never an error
        if not ratio <= MAX_OUTPUT_TIMES + 1:
            raise SpecError(f'output_times.every: {every:g} s gives {ratio:.3g} output times '
                            f'over {duration:g} s; at most {MAX_OUTPUT_TIMES}')
        count = min(math.floor(ratio * (1 + 1e-12)), MAX_OUTPUT_TIMES)
        times = [every * k for k in range(1, count + 1)]
    elif isinstance(value, list) and len(value) <= MAX_OUTPUT_TIMES:
        times = [_positive(f'output_times[{k}]', item) for k, item in enumerate(value)]
    else:
        raise SpecError(f'Expected output_times to be a list of times or {{every: seconds}}, '
                        f'got {quote(value)}')
    if any(t > duration * (1 + 1e-12) for t in times) or times != sorted(set(times)):
        raise SpecError(f'Expected output_times to increase within (0, duration], got '
                        f'{quote(value)}')
    if not times or abs(times[-1] - duration) > 1e-12 * duration:
        times.append(duration)
    times[-1] = duration
    return tuple(times)


def _controller_target(scene: Scene) -> FloatArray:
    """The attitude the scene's controller steers to, or the scene's initial attitude."""
    for effect in scene.build_effects():
        if isinstance(effect, AttitudePD):
            return np.array(effect.target)
    return scene.initial_attitude


def _settling(statistics: Mapping[Any, Any], scene: Scene) -> float:
    """``statistics.settling_deg``: closed-loop scenes only, in (0, 180]."""
    closed = any(name == CONTROLLER_EFFECT for name, _ in scene.effects)
    if 'settling_deg' not in statistics:
        return 1.0
    if not closed:
        raise SpecError(f'statistics.settling_deg needs a scene with the {CONTROLLER_EFFECT} '
                        f'effect (a closed loop)')
    value = _positive('statistics.settling_deg', statistics['settling_deg'])
    if value > 180.0:
        raise SpecError(f'Expected statistics.settling_deg to be at most 180, got {value!r}')
    return value


def _inertia(value: Any) -> InertiaDispersion | None:
    if value is None:
        return None
    value = _mapping('dispersions.inertia', value,
                     {'second_moments_sigma', 'axes', 'tensor_sigma'})
    if 'tensor_sigma' in value and len(value) > 1:
        raise SpecError('Expected dispersions.inertia to be either tensor_sigma or '
                        'second_moments_sigma with axes, not both')
    axes, cone = _attitude(value.get('axes', 'nominal'), 'dispersions.inertia.axes')
    return InertiaDispersion(
        second_moments_sigma=_nonnegative('dispersions.inertia.second_moments_sigma',
                                          value.get('second_moments_sigma', 0.0)),
        axes=axes, axes_cone=cone,
        tensor_sigma=_nonnegative('dispersions.inertia.tensor_sigma',
                                  value.get('tensor_sigma', 0.0)))


def _attitude(value: Any, key: str = 'dispersions.attitude') -> tuple[str, float]:
    if value in ('nominal', 'uniform'):
        return str(value), 0.0
    if isinstance(value, Mapping) and set(value) == {'cone_deg'}:
        cone = _nonnegative(f'{key}.cone_deg', value['cone_deg'])
        if cone > 180.0:
            raise SpecError(f'Expected {key}.cone_deg to be at most 180, got {cone!r}')
        return 'cone', math.radians(cone)
    raise SpecError(f'Expected {key} to be nominal, uniform or {{cone_deg: degrees}}, got '
                    f'{quote(value)}')


def _spread(key: str, value: Any, size: int, kinds: tuple[str, ...]) -> Spread:
    if not isinstance(value, Mapping) or len(value) != 1 or next(iter(value)) not in kinds:
        raise SpecError(f'Expected {key} to be one of {{{", ".join(kinds)}: ...}}, got '
                        f'{quote(value)}')
    kind, raw = next(iter(value.items()))
    where = f'{key}.{kind}'
    if kind == 'uniform':
        if not isinstance(raw, list) or len(raw) != 2:
            raise SpecError(f'Expected {where} to be [low, high], got {quote(raw)}')
        low, high = _vector(f'{where}[0]', raw[0], size), _vector(f'{where}[1]', raw[1], size)
        if np.any(low > high):
            raise SpecError(f'Expected {where} low <= high, got {quote(raw)}')
        return Spread(kind, low=low, high=high)
    sigma = _vector(where, raw, size)
    if np.any(sigma < 0.0):
        raise SpecError(f'Expected {where} to be >= 0, got {quote(raw)}')
    if kind == 'half_range':
        return Spread('uniform', low=-sigma, high=sigma)
    return Spread(kind, sigma=sigma)


def _optional_spread(key: str, value: Any, size: int,
                     kinds: tuple[str, ...]) -> Spread | None:
    return None if value is None else _spread(key, value, size, kinds)


def _effects(value: Any, scene: Scene, commands: bool) -> dict[str, dict[str, Spread]]:
    value = _mapping('dispersions.effects', value)
    named = dict(scene.effects)
    result: dict[str, dict[str, Spread]] = {}
    effects = {effect.name: effect for effect in scene.build_effects()}
    for name, parameters in value.items():
        if name == COMMAND_EFFECT and scene.effects[-1][0] == COMMAND_EFFECT and commands:
            raise SpecError(f'dispersions.effects.{name} carries the commands: disperse them '
                            f'with dispersions.commands')
        if name not in named:
            raise SpecError(f'Unknown effect {quote(name)} in dispersions.effects; the scene '
                            f'names: {", ".join(sorted(named)) or "none"}')
        parameters = _mapping(f'dispersions.effects.{name}', parameters)
        result[name] = {}
        for parameter, spread in parameters.items():
            key = f'dispersions.effects.{name}.{parameter}'
            if parameter in effects[name].renamed_parameters:
                raise SpecError(f'{key}: the parameter is named '
                                f'{effects[name].renamed_parameters[parameter]!r}: rename it')
            if parameter in effects[name].shared_parameters:
                raise SpecError(f'{key}: every run shares {parameter} (it cannot be '
                                f'dispersed)')
            nominal = effects[name].params.get(parameter)
            if isinstance(nominal, bool) or not isinstance(nominal, (float, int, np.ndarray)):
                raise SpecError(f'Expected {key} to name a numeric parameter of {name}; '
                                f'numeric ones: {", ".join(_numeric(effects[name].params))}')
            size = int(np.size(nominal))
            result[name][parameter] = _spread(key, spread, size,
                                              ('sigma', 'relative_sigma', 'uniform'))
    return result


def _numeric(params: Mapping[str, Any]) -> list[str]:
    return sorted(name for name, value in params.items()
                  if not isinstance(value, bool) and isinstance(value, (float, int, np.ndarray)))


def _command_dispersion(value: Any, commands: tuple[tuple[float, FloatArray], ...]
                        ) -> CommandDispersion | None:
    if value is None:
        return None
    if not commands:
        raise SpecError('dispersions.commands needs commands to disperse')
    value = _mapping('dispersions.commands', value, {'sigma'}, ('sigma',))
    sigma = _vector('dispersions.commands.sigma', value['sigma'])
    if np.any(sigma < 0.0):
        raise SpecError(f'Expected dispersions.commands.sigma to be >= 0, got '
                        f'{sigma.tolist()}')
    return CommandDispersion(sigma)


def _percentiles(value: Any) -> tuple[float, ...]:
    if not isinstance(value, list) or not 1 <= len(value) <= 99:
        raise SpecError(f'Expected statistics.percentiles to be a list of 1 to 99 numbers, '
                        f'got {quote(value)}')
    result = tuple(_FIELDS.number(item, f'statistics.percentiles[{k}]')
                   for k, item in enumerate(value))
    if any(not 0.0 <= p <= 100.0 for p in result):
        raise SpecError(f'Expected statistics.percentiles within [0, 100], got {quote(value)}')
    return result
