"""Scenes: what to simulate, read from YAML and validated once, before anything runs.

A scene names the body, the initial state, the rate source, the integrator and its step, and
the effects; only the effects it names are constructed. Format::

    name: torque_free_box
    description: a free box tumbling about no principal axis
    rate_source: dynamics          # or gyro (strapdown from measured rates)
    integrator: rk4                # default rk4; gyro scenes: delta_single
    step: 0.001                    # [s]; for gyro scenes the input stamps set the step
    body:
      mass: 2.0                    # [kg]
      inertia: {box: {edges: [0.1, 0.2, 0.3], about: centre}}
      # or inertia: {tensor: [[...], [...], [...]]} | {moments: [J1, J2, J3]}
      #    | {cylinder: {radius, height}} | {sphere: {radius}}
    initial_state:
      attitude: [1, 0, 0, 0]       # (w, x, y, z), normalised on load
      omega_body: [0.1, 2.0, 0.05] # [rad/s]
    effects:                       # list of {effect_name: {parameters}} or effect_name
      - viscous_damping: {coefficient: 0.01}
    sensors:                       # dynamics scenes: simulated sensors (core/sensors)
      imu: {rate: 200.0, frame_id: imu_link, seed: 1}
      magnetometer: {rate: 100.0, noise_density: 1.0e-8, intensity: 5.0e-5, inclination: 1.2}
      star_tracker: {rate: 5.0, boresight: [0, 0, 1], sun_exclusion_angle: 0.5}
    sun: {direction: [1, 0, 0]}    # world axes, towards the Sun (core/environment/sun.py)
    orbit: {altitude: 500000.0, inclination_deg: 97.4}   # spacecraft scenes (world: inertial)
    magnetic_field: {model: tilted_dipole}               # or igrf, local (core/environment)
    estimation: {magnetometer: true}  # gyro scenes: the filter's updates
                                   # (core/estimation/estimation_section.py)

Built-in scenes live in ``config/scenes/`` and are found by name (see :func:`scene_path`).

Hostile or broken files are refused at load with one :class:`SceneError` naming the file and
the key path (``initial_state.attitude``), or the line and column of a YAML syntax error; error
texts quote at most 100 characters of a bad value. Limits:

* the file checks of :mod:`~rigid_body_attitude.core.yaml_files`: at most 64 KiB (the shipped
  scenes are under 1 KiB), UTF-8, no YAML aliases, nesting at most 32 levels, every integer
  fits a float;
* ``name`` at most :data:`MAX_NAME_CHARS` characters, ``description`` at most
  :data:`MAX_DESCRIPTION_CHARS`;
* physics that stays finite: mass, principal moments and their inverses, ``|omega_body|``,
  the initial kinetic energy ``½ ωᵀJω`` and ``|Jω|``, and the attitude's magnitude before
  normalisation all within ``[1/SCALE_LIMIT, SCALE_LIMIT]`` (zero allowed for rates and
  energies). With :data:`SCALE_LIMIT` = 1e75 a product of two such quantities (``ω × Jω``,
  ``J⁻¹τ``) is at most 1e150 and its squared norm at most 1e300, below the float maximum
  (1.8e308); real bodies are far inside (the Earth: 8e37 kg m², 7e33 kg m²/s).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.dynamics.effects import (
    EFFECTS, BodyProperties, Effect, Environment, SampledTorque)
from rigid_body_attitude.core.environment.magnetic_field import MagneticFieldModel
from rigid_body_attitude.core.environment.orbit import CircularOrbit
from rigid_body_attitude.core.environment.sections import (
    magnetic_field_section, orbit_section)
from rigid_body_attitude.core.errors import AttitudeError, InertiaError, SceneError
from rigid_body_attitude.core.dynamics.euler import inertia_without_rotors
from rigid_body_attitude.core.dynamics.inertia import Inertia
from rigid_body_attitude.core.environment.sun import ConstantSunDirection, sun_section
from rigid_body_attitude.core.estimation.estimation_section import (
    EstimationSpec, estimation_section)
from rigid_body_attitude.core.paths import config_folders
from rigid_body_attitude.core.sensors.imu import ImuSpec
from rigid_body_attitude.core.sensors.magnetometer import MagnetometerSpec
from rigid_body_attitude.core.sensors.star_tracker import StarTrackerSpec
from rigid_body_attitude.core.sensors.suite import SensorSuite, sensors_section
from rigid_body_attitude.core.yaml_files import (
    bounded as _bounded, Fields, MAGNITUDE_LIMIT, quote, read_yaml, real)

__all__ = ['MAX_DESCRIPTION_CHARS', 'MAX_NAME_CHARS', 'RATE_SOURCES', 'SCALE_LIMIT', 'Scene',
           'builtin_scenes', 'load_scene', 'scene_from_mapping', 'scene_path']

FloatArray = NDArray[np.float64]

RATE_SOURCES = ('dynamics', 'gyro')
_TOP_KEYS = {'name', 'description', 'rate_source', 'integrator', 'step', 'body',
             'initial_state', 'effects', 'sensors', 'sun', 'orbit', 'magnetic_field',
             'estimation'}
_REQUIRED_TOP_KEYS = ('rate_source', 'body')
_BODY_KEYS = {'mass', 'inertia'}
_STATE_KEYS = {'attitude', 'omega_body'}
_SHAPES = ('tensor', 'moments', 'box', 'cylinder', 'sphere')
_DEFAULT_INTEGRATOR = {'dynamics': 'rk4', 'gyro': 'delta_single'}
_FIELDS = Fields(SceneError)

#: Longest ``name`` and ``description`` [characters].
MAX_NAME_CHARS = 256
MAX_DESCRIPTION_CHARS = 1024
#: Bound on every physical magnitude of a scene (SI units), and 1/bound on the positive ones
#: (the effects' parameters share it).
SCALE_LIMIT = MAGNITUDE_LIMIT


@dataclass(frozen=True)
class Scene:
    """A validated scene; :meth:`build_effects` constructs the named effects (only those).

    Attributes:
        name: scene name.
        description: one line for logs and docs.
        rate_source: ``'dynamics'`` (Euler's equations) or ``'gyro'`` (measured rates).
        integrator: integrator name (see :mod:`rigid_body_attitude.core.dynamics.integrators`).
        step: integration step [s] for dynamics scenes.
        inertia: validated inertia [kg m²], body axes.
        mass: [kg].
        initial_attitude: unit quaternion (w, x, y, z), body → world.
        initial_omega_body: [rad/s].
        effects: ``(name, parameters)`` pairs in scene order.
        source: the file it came from, if any.
        sensors: the simulated sensors of the ``sensors`` section (:attr:`imu`,
            :attr:`magnetometer`, :attr:`star_tracker`: each None when not named).
        sun: the Sun's direction of the ``sun`` section, or None.
        orbit: the ``orbit`` section (world: Earth-centred inertial), or None.
        magnetic_field: the ``magnetic_field`` section's model, or None.
        estimation: the measurement updates of the ``estimation`` section (gyro scenes), or
            None (pure propagation).
    """

    name: str
    description: str
    rate_source: str
    integrator: str
    step: float
    inertia: Inertia
    mass: float
    initial_attitude: FloatArray
    initial_omega_body: FloatArray
    effects: tuple[tuple[str, Mapping[str, Any]], ...] = field(default_factory=tuple)
    source: str = ''
    sensors: SensorSuite = field(default_factory=SensorSuite)
    sun: ConstantSunDirection | None = None
    orbit: CircularOrbit | None = None
    magnetic_field: MagneticFieldModel | None = None
    estimation: EstimationSpec | None = None

    @property
    def imu(self) -> ImuSpec | None:
        """The simulated IMU, or None."""
        return self.sensors.imu

    @property
    def magnetometer(self) -> MagnetometerSpec | None:
        """The simulated magnetometer, or None."""
        return self.sensors.magnetometer

    @property
    def star_tracker(self) -> StarTrackerSpec | None:
        """The simulated star tracker, or None."""
        return self.sensors.star_tracker

    def build_effects(self) -> list[Effect]:
        """Construct the scene's effects, in order, and link them (:meth:`Effect.bind`);
        nothing else is built."""
        body = BodyProperties(self.inertia, self.mass,
                              Environment(self.orbit, self.magnetic_field))
        effects = [EFFECTS[name](params, body) for name, params in self.effects]
        for effect in effects:
            effect.bind(effects)
        return effects

    def with_overrides(self, integrator: str = '', step: float = 0.0,
                       effect_parameters: Mapping[str, Mapping[str, Any]] | None = None
                       ) -> Scene:
        """A copy with another integrator or step, or some effect parameters replaced.

        ``effect_parameters`` maps an effect name to parameters merged into that effect's
        (ignored for effects the scene does not name). The copy is validated again.
        """
        effects = self.effects
        if effect_parameters:
            effects = tuple((name, {**params, **effect_parameters.get(name, {})})
                            for name, params in self.effects)
        changed = replace(self, integrator=integrator or self.integrator,
                          step=step or self.step, effects=effects)
        _check_effects(changed)
        _check_step(changed.step)
        _check_sensors(changed)
        return changed


def builtin_scenes() -> dict[str, Path]:
    """Names and files of the shipped scenes (``config/scenes/*.yaml``)."""
    found: dict[str, Path] = {}
    for folder in reversed(config_folders('scenes')):
        for path in sorted(folder.glob('*.yaml')):
            found[path.stem] = path
    return found


def scene_path(name_or_path: str) -> Path:
    """The file of a built-in scene name, or ``name_or_path`` itself if it is a file."""
    candidate = Path(name_or_path).expanduser()
    if candidate.suffix in ('.yaml', '.yml') or os.sep in name_or_path:
        if candidate.is_file():
            return candidate
        raise SceneError(f'Scene file {name_or_path!r} does not exist')
    scenes = builtin_scenes()
    if name_or_path in scenes:
        return scenes[name_or_path]
    raise SceneError(f'Unknown scene {name_or_path!r}; built-in scenes: '
                     f'{", ".join(sorted(scenes)) or "(none found)"}, or give a path to a '
                     f'.yaml file')


def load_scene(name_or_path: str) -> Scene:
    """Load and validate a built-in scene by name or a scene YAML file by path.

    Every fault is one :class:`SceneError` whose text starts ``Scene file '<path>'`` (see the
    module's limits); nothing else escapes for any file content.
    """
    path = scene_path(name_or_path)
    where = f'Scene file {str(path)!r}'
    data = read_yaml(path, where, SceneError, 'scene files')
    try:
        return scene_from_mapping(data, default_name=path.stem, source=str(path))
    except SceneError as err:
        raise SceneError(_bounded(f'{where}: {err}')) from None


def scene_from_mapping(data: Any, default_name: str = 'scene', source: str = '') -> Scene:
    """Validate a scene given as a mapping (the parsed YAML).

    Errors name the key path (``body.mass``, ``initial_state.attitude``) and quote at most
    100 characters of the bad value.
    """
    if not isinstance(data, Mapping):
        raise SceneError(f'Expected a scene to be a mapping with keys '
                         f'{", ".join(sorted(_TOP_KEYS))}, got {quote(data)}')
    _FIELDS.keys(data, _TOP_KEYS, 'scene', _REQUIRED_TOP_KEYS)
    rate_source = data['rate_source']
    if rate_source not in RATE_SOURCES:
        raise SceneError(f'Unknown rate_source {quote(rate_source)}; valid choices: '
                         f'{", ".join(RATE_SOURCES)}')
    with np.errstate(all='ignore'):  # overflow is refused below, not warned about
        inertia, mass = _body(data['body'])
        attitude, omega = _initial_state(data.get('initial_state', {}), inertia)
    orbit = orbit_section(data.get('orbit'))
    scene = Scene(
        name=_label('name', data.get('name', default_name), MAX_NAME_CHARS),
        description=_label('description', data.get('description', ''), MAX_DESCRIPTION_CHARS),
        rate_source=rate_source,
        integrator=_text('integrator', data.get('integrator', _DEFAULT_INTEGRATOR[rate_source])),
        step=_check_step(data.get('step', 0.001)),
        inertia=inertia,
        mass=mass,
        initial_attitude=attitude,
        initial_omega_body=omega,
        effects=_effect_list(data.get('effects') or []),
        source=source,
        sensors=sensors_section(data.get('sensors')),
        sun=sun_section(data.get('sun')),
        orbit=orbit,
        magnetic_field=magnetic_field_section(data.get('magnetic_field'), orbit),
        estimation=estimation_section(data.get('estimation')),
    )
    if scene.estimation is not None and rate_source != 'gyro':
        raise SceneError('estimation: the measurement updates need a gyro scene (rate_source: '
                         'gyro)')
    _check_effects(scene)
    _check_sensors(scene)
    return scene


def _text(key: str, value: Any) -> str:
    if not isinstance(value, str):
        raise SceneError(f'Expected {key!r} to be a string, got {quote(value)}')
    return value


def _label(key: str, value: Any, limit: int) -> str:
    """A name or description: text (numbers are written as text), at most ``limit`` chars."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = str(value)
    text = _text(key, value)
    if len(text) > limit:
        raise SceneError(f'Expected {key!r} to be at most {limit} characters, got '
                         f'{len(text)}: {quote(text)}')
    return text


def _number(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        try:
            real(value)  # always raises here; its reason explains YAML 1.1's '1e-3' text
        except (TypeError, ValueError) as err:
            raise SceneError(f'Expected {key!r} to be {err}, got {quote(value)}') from err
    try:
        return float(value)
    except OverflowError:
        raise SceneError(f'Expected {key!r} to be a number within the float range, got '
                         f'{quote(value)}') from None


def _check_step(value: Any) -> float:
    step = _number('step', value)
    if not np.isfinite(step) or step <= 0.0:
        raise SceneError(f'Expected step to be a positive number of seconds, got {quote(value)}')
    return step


def _body(data: Any) -> tuple[Inertia, float]:
    data = _FIELDS.mapping(data, 'body', _BODY_KEYS, ('inertia',))
    mass = _number('body.mass', data.get('mass', 1.0))
    if not np.isfinite(mass) or mass <= 0.0:
        raise SceneError(f'Expected body.mass to be a positive number [kg], got {mass!r}')
    _within_scale('body.mass', mass, positive=True)
    spec = data['inertia']
    if not isinstance(spec, Mapping) or len(spec) != 1 or next(iter(spec)) not in _SHAPES:
        raise SceneError(f'Expected body.inertia to be one of {{{", ".join(_SHAPES)}: ...}}, '
                         f'got {quote(spec)}')
    kind, params = next(iter(spec.items()))
    try:
        inertia = _inertia(kind, params, mass)
    except AttitudeError as err:
        raise SceneError(_bounded(f'Bad body.inertia.{kind}: {err}')) from err
    except (TypeError, OverflowError) as err:
        raise SceneError(_bounded(f'Bad body.inertia.{kind} parameters {quote(params)}: '
                                  f'{err}')) from err
    for moment in inertia.principal_moments.tolist():
        _within_scale(f'body.inertia.{kind} (principal moment)', moment, positive=True)
    return inertia, mass


def _inertia(kind: str, params: Any, mass: float) -> Inertia:
    if kind in ('tensor', 'moments'):
        return Inertia(params)
    if not isinstance(params, Mapping):
        raise SceneError(f'Expected body.inertia.{kind} to be a mapping, got {quote(params)}')
    if kind == 'box':
        return Inertia.box(mass, **params)
    if kind == 'cylinder':
        return Inertia.cylinder(mass, **params)
    return Inertia.sphere(mass, **params)


def _within_scale(key: str, value: float, positive: bool = False) -> None:
    """Refuse a magnitude above :data:`SCALE_LIMIT` (or, if ``positive``, below its inverse)."""
    if not abs(value) <= SCALE_LIMIT or (positive and not abs(value) >= 1.0 / SCALE_LIMIT):
        bounds = f'[{1.0 / SCALE_LIMIT:g}, {SCALE_LIMIT:g}]' if positive else (
            f'at most {SCALE_LIMIT:g}')
        raise SceneError(f'Expected {key} to be {bounds} so that the physics stays finite, '
                         f'got {value:.6g}')


def _initial_state(data: Any, inertia: Inertia) -> tuple[FloatArray, FloatArray]:
    data = _FIELDS.mapping(data, 'initial_state', _STATE_KEYS)
    try:
        raw_attitude = quaternion.as_quaternion(data.get('attitude', [1.0, 0.0, 0.0, 0.0]),
                                                'initial_state.attitude')
        omega = quaternion.as_vector(data.get('omega_body', [0.0, 0.0, 0.0]),
                                     'initial_state.omega_body')
    except AttitudeError as err:
        raise SceneError(_bounded(str(err))) from err
    except OverflowError as err:
        raise SceneError(f'Expected initial_state to hold numbers within the float range: '
                         f'{err}') from err
    if raw_attitude.shape != (4,) or omega.shape != (3,):
        raise SceneError('Expected initial_state.attitude to be 4 numbers (w, x, y, z) and '
                         f'omega_body 3 numbers, got {quote(data)}')
    largest = float(np.max(np.abs(raw_attitude)))
    if largest == 0.0:
        raise SceneError(f'Expected initial_state.attitude to be a non-zero quaternion '
                         f'(w, x, y, z), got {raw_attitude.tolist()!r}')
    _within_scale('initial_state.attitude (largest component)', largest, positive=True)
    attitude = quaternion.normalize(raw_attitude)
    _within_scale('|initial_state.omega_body| [rad/s]', _norm(omega))
    momentum = inertia.tensor @ omega
    _within_scale('the initial angular momentum |J omega_body| [kg m²/s]', _norm(momentum))
    _within_scale('the initial kinetic energy [J]', 0.5 * float(omega @ momentum))
    return attitude, omega


def _norm(vector: FloatArray) -> float:
    """Euclidean norm without overflow in the squares (components are finite)."""
    scale = float(np.max(np.abs(vector)))
    return 0.0 if scale == 0.0 else scale * math.sqrt(float(np.sum((vector / scale) ** 2)))


def _effect_list(data: Any) -> tuple[tuple[str, Mapping[str, Any]], ...]:
    if not isinstance(data, list):
        raise SceneError(f'Expected effects to be a list, got {quote(data)}')
    effects = []
    for index, item in enumerate(data):
        params: Any
        if isinstance(item, str):
            name, params = item, {}
        elif isinstance(item, Mapping) and len(item) == 1:
            name, params = next(iter(item.items()))
            params = {} if params is None else params
        else:
            raise SceneError(f'Expected effects[{index}] to be a name or '
                             f'{{name: {{parameters}}}}, got {quote(item)}')
        if not isinstance(name, str) or name not in EFFECTS:
            raise SceneError(f'Unknown effect {quote(name)}; valid effects: '
                             f'{", ".join(sorted(EFFECTS))}')
        if not isinstance(params, Mapping):
            raise SceneError(f'Expected the parameters of effect {name!r} to be a mapping, '
                             f'got {quote(params)}')
        effects.append((name, dict(params)))
    return tuple(effects)


def _check_effects(scene: Scene) -> None:
    names = [name for name, _ in scene.effects]
    for name in names:
        cls = EFFECTS[name]
        if names.count(name) > 1:
            raise SceneError(f'Effect {name!r} is named more than once in scene '
                             f'{quote(scene.name)}')
        if scene.rate_source not in cls.rate_sources:
            raise SceneError(f'Effect {name!r} applies to {"/".join(sorted(cls.rate_sources))} '
                             f'scenes, not to rate_source {scene.rate_source!r}')
        for required in cls.requires:
            if required not in names:
                raise SceneError(f'Effect {name!r} needs effect {required!r} in the same scene')
    try:
        built = scene.build_effects()
    except SceneError as err:
        raise SceneError(_bounded(str(err))) from err
    except (AttitudeError, TypeError, OverflowError) as err:
        raise SceneError(_bounded(f'effects: {err}')) from err
    try:
        inertia_without_rotors(scene.inertia, built)
    except InertiaError as err:
        raise SceneError(_bounded(f'body.inertia minus the wheels\' spin inertia (the inertia '
                                  f'the body keeps around spinning wheels) is not an inertia: '
                                  f'{err}')) from err
    for effect in built:
        effect.check_step(scene.step)
        if isinstance(effect, SampledTorque):
            steps = effect.period / scene.step
            if not (round(steps) >= 1 and abs(steps - round(steps)) <= 1e-9 * steps):
                raise SceneError(f'Effect {effect.name!r}: control_period {effect.period!r} s '
                                 f'must be a whole number of steps of {scene.step!r} s')


#: Effects that give the world gravity a simulated accelerometer feels.
GRAVITY_EFFECTS = ('uniform_gravity', 'gravity_about_pivot')


def _check_sensors(scene: Scene) -> None:
    """Simulated sensors: dynamics scenes only, each period a whole number of steps; the
    IMU's ``gravity`` only where no effect gives it (and the body does not translate); the
    magnetometer's field given once (the scene's field model or the section's local field);
    a Sun for the star tracker's exclusion angle."""
    sensors = list(scene.sensors.items())
    if not sensors:
        return
    if scene.rate_source != 'dynamics':
        raise SceneError('sensors: simulated sensors need a dynamics scene (rate_source: '
                         'dynamics)')
    for key, spec in sensors:
        ratio = spec.period / scene.step
        if round(ratio) < 1 or abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise SceneError(f'Expected the period of sensors.{key}.rate ({spec.period:.9g} s) '
                             f'to be a whole multiple of the step ({scene.step:g} s), got '
                             f'{ratio:.6g} steps')
    imu, magnetometer, star_tracker = scene.imu, scene.magnetometer, scene.star_tracker
    names = [name for name, _ in scene.effects]
    given_by = [name for name in names if name in GRAVITY_EFFECTS + ('translation',)]
    if imu is not None and imu.gravity is not None and given_by:
        raise SceneError(f'sensors.imu.gravity is for a body held in place without gravity '
                         f'effects; scene {quote(scene.name)} has {given_by[0]!r} (the '
                         f'accelerometer takes the gravity of its effects)')
    if magnetometer is not None and magnetometer.intensity is None and (
            scene.magnetic_field is None):
        raise SceneError('sensors.magnetometer needs the local field: intensity [T], '
                         'inclination and declination [rad], or the scene\'s magnetic_field '
                         'section')
    if magnetometer is not None and magnetometer.intensity is not None and (
            scene.magnetic_field is not None):
        raise SceneError('sensors.magnetometer.intensity gives a local field in a scene whose '
                         'magnetic_field section gives the field; give one of them')
    if star_tracker is not None and star_tracker.sun_exclusion_angle > 0.0 and scene.sun is None:
        raise SceneError('sensors.star_tracker.sun_exclusion_angle needs the Sun\'s direction: '
                         'a sun section (sun: {direction: [x, y, z]})')
