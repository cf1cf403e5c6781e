"""``attitude_controller``'s torque rods: B-dot and momentum dumping on the measured field.

With ``actuator`` ``magnetorquers`` (B-dot detumbling), or ``reaction_wheels`` and a
``dumping_gain`` (momentum dumping), the controller answers each tick with a dipole [A m²,
body axes] on ``dipole``, from the field a magnetometer measures (``imu/mag``,
``sensor_msgs/msg/MagneticField`` [T] in its own frame) rather than from any field model:

* **B-dot** (A. C. Stickler and K. T. Alfriend, "Elementary magnetic attitude control system",
  J. Spacecraft and Rockets 13(5):282-287, 1976; Markley and Crassidis, *Fundamentals of
  Spacecraft Attitude Determination and Control*, 2014, sec. 7.5): at each recomputation
  (``control_period``) ``m = −k (B_b − B_b,prev) / (t − t_prev)``, ``B_b`` the field of the
  tick's sample in body axes, ``B_b,prev`` that of the previous recomputation's (stamps ``t``,
  ``t_prev``); zero at the first, held when no newer sample came. The law of the scene's
  ``bdot`` effect (:func:`~rigid_body_attitude.core.control.magnetic.bdot_dipole`), on
  measured fields.
* **Dumping** (Markley and Crassidis 2014, ch. 7): ``m = k (h_w × B_b) / |B_b|²``, ``h_w =
  Σ Jₛᵢ Ωᵢ âᵢ`` the wheels' stored momentum from ``wheels/state`` (the speeds relative to the
  body, stamped like the tick) and the scene's spin inertias and axes
  (:func:`~rigid_body_attitude.core.control.magnetic.dumping_dipole`); the torque
  ``m × B_b = −k h_w,⊥`` takes out the momentum across the field while the wheels hold the
  attitude. Recomputed with the torque, held with it.

**Which sample, deterministically.** Tick ``k`` (stamp ``t_k``) uses the sample stamped
``⌊t_k / P⌋ P`` (integer nanoseconds), ``P`` the magnetometer's period (``magnetometer_period``,
or the rate of the scene's ``sensors.magnetometer``): the newest instant of its lattice at or
before the tick, which the plant's simulated magnetometer publishes before the tick's outputs.
The controller waits for it (and, dumping, for the tick's ``wheels/state``) as it waits for
the tick's state: its answers depend on the stamped inputs only, never on arrival order, so
two lockstep runs are bit-identical.

**Mount.** ``magnetometer_mount_rpy`` (the sensor frame in ``body_frame``, as
static_transform_publisher's angles), else the static transforms on ``/tf_static`` from
``body_frame`` to the sample's frame (composed along a chain, checked as the node's mount
gate checks them), else none needed for samples in ``body_frame``. A tick whose sample's mount
is unknown waits for it.

**Checks** (each refusal counted by reason in ``/diagnostics`` and warned about): a sample
with a non-finite component (``non_finite``), one beyond :data:`MAX_FIELD` T or whose largest
component is below :data:`MIN_FIELD` T, zero included (``out_of_range``); a wheel state
naming a wheel the scene's array does not have or one twice (``unknown_wheel``), leaving one
out (``missing_wheel``), with another number of speeds than names (``wheel_lengths``) or a
non-finite speed (``non_finite``). At most :data:`MAX_KEPT` samples and wheel states wait
for their ticks (the newest-stamped dropped beyond that, counted
``unpaired``: a flood of far-future stamps never pushes out the ones a tick needs). A second
message of a stamp already kept, different from the first, replaces it (the first counted
``repeated_stamp``), unless an answered tick used the first (the second counted); an equal
one changes nothing. One stamped before what the last answered tick used is kept while the
plant may restart at it, and counted ``stale_stamp`` when dropped unused. A tick whose
sample's mount never came before a later tick was answered counts as ``no_mount``.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from typing import Any, TypeVar

from rigid_body_attitude.core.attitude.quaternion import from_rpy, rotate_floats
from rigid_body_attitude.core.control.magnetic import bdot_dipole, dumping_dipole
from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.yaml_files import quote
from rigid_body_attitude.msgs.tf_message import Transform
from rigid_body_attitude.msgs.untrusted import quoted
from rigid_body_attitude.session.mount import StaticTransforms
from rigid_body_attitude.session.times import NANOSECONDS_PER_SECOND, seconds_to_ns
from rigid_body_attitude.session.wheel_drive import WheelDrive, commanded_rods

_Kept = TypeVar('_Kept')

__all__ = ['MAX_FIELD', 'MAX_KEPT', 'MIN_FIELD', 'MagneticControl', 'Refusal', 'magnetic_control']

Vector = tuple[float, float, float]
Quaternion = tuple[float, float, float, float]
#: A refused input: (reason, what to say), or ``('', '')``.
Refusal = tuple[str, str]

#: Largest field component taken [T] (the Earth's field is below 7e-5 T; no magnetometer of
#: attitude control measures a tesla).
MAX_FIELD = 1.0
#: Smallest largest field component taken [T]: the Earth's field is thousands of times
#: stronger, and dumping's ``k / |B|²`` of a weaker field (a magnetometer reading zero, or a
#: denormal) is no dipole any rod gives, or not finite.
MIN_FIELD = 1e-9
#: Samples (and wheel states) kept while waiting for their ticks.
MAX_KEPT = 256

_ZERO: Vector = (0.0, 0.0, 0.0)
_ACCEPTED: Refusal = ('', '')


class MagneticControl:
    """The rods' dipole of each tick: B-dot (``drive`` None) or dumping the wheels of
    ``drive``, from the magnetometer's samples."""

    def __init__(self, gain: float, period_ns: int, body_frame: str,
                 mount: Quaternion | None, drive: WheelDrive | None = None) -> None:
        """``gain``: B-dot's ``k`` [A m² s/T], or (with ``drive``) dumping's [1/s] (0: the
        rods idle, no field needed); ``period_ns``: the magnetometer's period; ``mount``: the
        sensor frame's rotation in ``body_frame`` (None: from :meth:`add_transforms`)."""
        self.gain, self.period_ns, self.body_frame = gain, period_ns, body_frame
        self.mount, self.drive = mount, drive
        self.transforms = StaticTransforms()
        #: Samples waiting for their ticks: stamp [ns] → (frame, field [T], sensor axes).
        self.fields: dict[int, tuple[str, Vector]] = {}
        #: Wheel states waiting for their ticks (dumping): stamp [ns] → speeds [rad/s].
        self.speeds: dict[int, tuple[float, ...]] = {}
        self._index = {} if drive is None else {name: i for i, name in enumerate(drive.names)}
        #: Refusals found while answering (stale messages dropped unused), for the session.
        self.refusals: list[Refusal] = []
        self.restart()

    @property
    def dumping(self) -> bool:
        """Whether the law is momentum dumping (else B-dot)."""
        return self.drive is not None

    @property
    def needs_field(self) -> bool:
        """Whether the dipole comes from the field (else the rods idle: a zero dipole)."""
        return self.gain > 0.0

    @property
    def inputs(self) -> tuple[str, ...]:
        """The controller interface's quantities it reads: the magnetometer, the wheels'
        state (dumping), the static transforms (no mount given)."""
        if not self.needs_field:
            return ()
        return ('magnetic_field', *(('wheel_state',) if self.dumping else ()),
                *(('transforms',) if self.mount is None else ()))

    def restart(self, tick_ns: int | None = None) -> None:
        """The plant started again (its time went back to ``tick_ns``): no previous sample
        (B-dot), a zero dipole held, nothing kept from after ``tick_ns``."""
        self.previous: tuple[int, Vector] | None = None
        self.dipole: Vector = _ZERO
        #: The last answered tick's stamp [ns] (None: none since the start or a restart).
        self.last_tick_ns: int | None = None
        #: Stamps of kept messages that came stamped before what the last tick used.
        self.stale: dict[str, set[int]] = {'imu/mag': set(), 'wheels/state': set()}
        if tick_ns is not None:
            for kept in (self.fields, self.speeds):
                for stamp in [stamp for stamp in kept if stamp > tick_ns]:
                    del kept[stamp]

    # -- inputs -----------------------------------------------------------------------------

    def magnetometer(self, stamp_ns: int, frame_id: str, field: Sequence[float]) -> Refusal:
        """One sample [T] in ``frame_id`` stamped ``stamp_ns``; the refusal, if any."""
        if not all(math.isfinite(value) for value in field):
            return 'non_finite', 'imu/mag: a non-finite field component (NaN or Inf)'
        largest = max(abs(value) for value in field)
        if largest > MAX_FIELD:
            return 'out_of_range', f'imu/mag: a field component beyond {MAX_FIELD:g} T'
        if largest < MIN_FIELD:
            return 'out_of_range', f'imu/mag: a field weaker than {MIN_FIELD:g} T (zero included)'
        x, y, z = field
        used = None if self.last_tick_ns is None else self.sample_ns(self.last_tick_ns)
        return self._keep(self.fields, stamp_ns, (frame_id, (x, y, z)), 'imu/mag', used)

    def wheel_state(self, stamp_ns: int, names: Sequence[str],
                    velocity: Sequence[float]) -> Refusal:
        """The plant's ``wheels/state`` (speeds relative to the body [rad/s])."""
        drive, index = self.drive, self._index
        if drive is None:
            return _ACCEPTED
        unknown = [name for name in names if name not in index]
        if unknown or len(set(names)) != len(names):
            shown = quoted(unknown[0]) if unknown else 'a name twice'
            return 'unknown_wheel', (f'wheels/state: {shown}; the wheels are '
                                     f'{", ".join(drive.names)}')
        if len(names) != len(drive.names):
            return 'missing_wheel', 'wheels/state: not every wheel of the scene named'
        if len(velocity) != len(names):
            return 'wheel_lengths', (f'wheels/state: {len(velocity)} speeds for {len(names)} '
                                     f'names')
        if not all(math.isfinite(value) for value in velocity):
            return 'non_finite', 'wheels/state: a non-finite speed (NaN or Inf)'
        ordered = [0.0] * len(names)
        for name, value in zip(names, velocity):
            ordered[index[name]] = value
        return self._keep(self.speeds, stamp_ns, tuple(ordered), 'wheels/state',
                          self.last_tick_ns)

    def add_transforms(self, transforms: Iterable[Transform]) -> Counter[str]:
        """Static transforms from ``/tf_static``; how many were refused, by reason."""
        return self.transforms.add_all(transforms)

    def _keep(self, kept: dict[int, _Kept], stamp_ns: int, value: _Kept, topic: str,
              used_ns: int | None) -> Refusal:
        """Keep ``value`` for the ticks; ``used_ns``: the stamp the last answered tick used."""
        refusal = _ACCEPTED
        if stamp_ns in kept:
            if kept[stamp_ns] == value:
                return _ACCEPTED
            if stamp_ns == used_ns:
                return 'repeated_stamp', (f'{topic}: a second, different message stamped like '
                                          f'the one an answered tick used; ignored')
            refusal = 'repeated_stamp', (f'{topic}: a second, different message of one stamp; '
                                         f'the first dropped')
        elif used_ns is not None and stamp_ns < used_ns:
            self.stale[topic].add(stamp_ns)
        kept[stamp_ns] = value
        if len(kept) > MAX_KEPT:
            del kept[max(kept)]
            return 'unpaired', (f'{topic}: more than {MAX_KEPT} messages waiting for their '
                                f'ticks; the newest-stamped dropped')
        return refusal

    # -- ticks ------------------------------------------------------------------------------

    def sample_ns(self, tick_ns: int) -> int:
        """The stamp of tick ``tick_ns``'s magnetometer sample: ``⌊t / P⌋ P``."""
        return tick_ns // self.period_ns * self.period_ns

    def waiting_for(self, tick_ns: int) -> str:
        """What tick ``tick_ns`` still waits for (``''``: nothing)."""
        if not self.needs_field:
            return ''
        sample_ns = self.sample_ns(tick_ns)
        sample = self.fields.get(sample_ns)
        if sample is None:
            return f'the imu/mag sample stamped {sample_ns * 1e-9:.9f} s'
        if self._rotation(sample[0]) is None:
            return (f'the static transform {quoted(self.body_frame)} -> {quoted(sample[0])} '
                    f'on /tf_static (or parameter `magnetometer_mount_rpy`)')
        if self.drive is not None and tick_ns not in self.speeds:
            return f'the wheels/state stamped {tick_ns * 1e-9:.9f} s'
        return ''

    def lacks_mount(self, tick_ns: int) -> bool:
        """Whether tick ``tick_ns``'s sample came but its frame's mount is unknown."""
        sample = self.fields.get(self.sample_ns(tick_ns)) if self.needs_field else None
        return sample is not None and self._rotation(sample[0]) is None

    def answer(self, tick_ns: int, recompute: bool) -> Vector:
        """The dipole [A m², body] answering the ready tick ``tick_ns``: recomputed (at the
        first tick of a control interval) or held."""
        if recompute and self.needs_field:
            sample_ns = self.sample_ns(tick_ns)
            field = self.field_body(sample_ns)
            if self.drive is not None:
                stored = self.drive.stored_momentum(self.speeds[tick_ns])
                self.dipole = dumping_dipole(stored, field, self.gain)
            elif self.previous is None or self.previous[0] < sample_ns:
                previous = self.previous
                self.dipole = (_ZERO if previous is None else bdot_dipole(
                    field, previous[1], (sample_ns - previous[0]) / NANOSECONDS_PER_SECOND,
                    self.gain))
                self.previous = (sample_ns, field)
        self.last_tick_ns = tick_ns
        self._forget_before(tick_ns)
        return self.dipole

    def field_body(self, sample_ns: int) -> Vector:
        """The field [T] of the sample stamped ``sample_ns`` in body axes (its mount known)."""
        frame, field = self.fields[sample_ns]
        rotation = self._rotation(frame)
        assert rotation is not None
        return rotate_floats(rotation, field)

    def _rotation(self, frame: str) -> Quaternion | None:
        """The rotation mapping ``frame``'s vectors into ``body_frame``'s, or None."""
        if self.mount is not None:
            return self.mount
        if frame == self.body_frame:
            return 1.0, 0.0, 0.0, 0.0
        return self.transforms.rotation(self.body_frame, frame)

    def _forget_before(self, tick_ns: int) -> None:
        """Drop what no later tick needs (ticks come in stamp order)."""
        kept: tuple[tuple[str, dict[int, Any], int], ...] = (
            ('imu/mag', self.fields, self.sample_ns(tick_ns)),
            ('wheels/state', self.speeds, tick_ns))
        for topic, messages, first_needed in kept:
            stale = self.stale[topic]
            for stamp in [stamp for stamp in messages if stamp < first_needed]:
                del messages[stamp]
                if stamp in stale:
                    stale.discard(stamp)
                    self.refusals.append(('stale_stamp', (
                        f'{topic}: stamped before what the last answered tick used, and no '
                        f'tick went back to it; dropped')))


def magnetic_control(values: Mapping[str, Any], scene: Scene | None,
                     drive: WheelDrive | None) -> MagneticControl | None:
    """The controller's rods for its checked parameter ``values``: ``actuator``
    ``magnetorquers``, B-dot; ``reaction_wheels`` on a scene whose rods take dipole commands,
    dumping the wheels of ``drive`` (a ``dumping_gain`` of 0: a zero dipole); else None.
    ``scene``: the plant's, for its magnetometer's rate. InputError when the field is needed
    and the magnetometer's period is known from neither the parameters nor the scene, or a
    ``dumping_gain`` has no rods to act with."""
    if values['actuator'] == 'magnetorquers':
        gain, drive = values['bdot_gain'], None
        if scene is not None and not commanded_rods(scene.build_effects()):
            raise InputError(f'Expected scene {quote(scene.name)} to have magnetorquers that '
                             f'take dipole commands (parameter `actuator` magnetorquers), got '
                             f'none')
    elif drive is not None and drive.answers_dipole:
        gain = values['dumping_gain']
    elif values['dumping_gain'] > 0.0:
        raise InputError(f'Expected scene {quote(values["scene"])} to have magnetorquers that '
                         f'take dipole commands for parameter `dumping_gain`, got none')
    else:
        return None
    period_ns = seconds_to_ns(values['magnetometer_period'])
    if not period_ns and scene is not None and scene.sensors.magnetometer is not None:
        period_ns = scene.sensors.magnetometer.period_ns
    if not period_ns and gain > 0.0:
        raise InputError('Expected parameter `magnetometer_period` > 0 or a `scene` with a '
                         'sensors.magnetometer section (the magnetometer\'s period), got neither')
    mount = None
    if values['magnetometer_mount_rpy']:
        w, x, y, z = from_rpy(values['magnetometer_mount_rpy']).tolist()
        mount = (w, x, y, z)
    return MagneticControl(gain, period_ns or 1, values['body_frame'], mount, drive)
