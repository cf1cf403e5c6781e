"""The controller's magnetic inputs, and its ticks that wait for them.

:class:`MagneticTicks` is the part of :class:`~rigid_body_attitude.session.controller.
ControllerSession` that serves its torque rods (:mod:`~rigid_body_attitude.session.
magnetic_control`): the magnetometer's samples (``imu/mag``), the plant's wheel speeds
(``wheels/state``, dumping) and the static transforms (``/tf_static``, the magnetometer's
mount) go to the :class:`~.magnetic_control.MagneticControl`, each refusal counted by reason;
a tick whose state is complete but whose magnetometer sample, its mount or its wheel state has
not come yet waits (:meth:`MagneticTicks.park`, at most :data:`MAX_PARKED` ticks, the oldest
dropped beyond that and counted ``unpaired``) and is answered, in stamp order, as soon as it
has them.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Iterable, Sequence

from rigid_body_attitude.msgs.tf_message import Transform
from rigid_body_attitude.session.magnetic_control import MagneticControl, Refusal
from rigid_body_attitude.session.mount import transform_warning
from rigid_body_attitude.session.times import stamp_problem, to_ns

__all__ = ['MAX_PARKED', 'MagneticTicks']

#: Complete ticks kept while they wait for their magnetometer sample.
MAX_PARKED = 64

Values = tuple[float, ...]


class MagneticTicks(ABC):
    """The magnetic inputs of a controller session and its waiting ticks (a mixin: the
    session gives :meth:`_reject` and :meth:`_answer`)."""

    magnetic: MagneticControl | None
    #: Complete ticks waiting for their magnetometer sample: stamp → (attitude, rate).
    parked: dict[int, tuple[Values, Values]]

    @abstractmethod
    def _reject(self, reason: str, text: str) -> None:
        """Count and warn about a refused input (the session's)."""

    @abstractmethod
    def _answer(self, stamp_ns: int, attitude: Values, rate: Values) -> None:
        """Answer a complete tick (the session's)."""

    def magnetometer(self, sec: int, nanosec: int, frame_id: str,
                     field: Sequence[float]) -> None:
        """A magnetometer sample [T] in ``frame_id`` (``imu/mag``)."""
        self._magnetic_input('imu/mag', sec, nanosec, lambda magnetic, stamp_ns: (
            magnetic.magnetometer(stamp_ns, frame_id, field)))

    def wheel_state(self, sec: int, nanosec: int, names: Sequence[str],
                    velocity: Sequence[float]) -> None:
        """The plant's wheel speeds [rad/s] relative to the body (``wheels/state``)."""
        self._magnetic_input('wheels/state', sec, nanosec, lambda magnetic, stamp_ns: (
            magnetic.wheel_state(stamp_ns, names, velocity)))

    def transforms(self, transforms: Iterable[Transform]) -> None:
        """Static transforms (``/tf_static``): the magnetometer's mount."""
        magnetic = self.magnetic
        if magnetic is None:
            return
        for reason, count in magnetic.add_transforms(transforms).items():
            example = magnetic.transforms.examples.get(reason, ('', ''))
            for _ in range(count):
                self._reject(reason, transform_warning(reason, count, example, '/tf_static'))
        self.release()

    def _magnetic_input(self, topic: str, sec: int, nanosec: int,
                        take: Callable[[MagneticControl, int], Refusal]) -> None:
        problem = stamp_problem(sec, nanosec)
        if problem:
            self._reject('invalid_stamp', f'{topic}: an invalid header stamp ({problem})')
        elif self.magnetic is not None:
            reason, text = take(self.magnetic, to_ns(sec, nanosec))
            if reason:
                self._reject(reason, text)
            self.release()

    def park(self, stamp_ns: int, attitude: Values, rate: Values) -> None:
        """A complete tick waits for its magnetometer sample (or its mount, its wheel
        state)."""
        self.parked[stamp_ns] = (attitude, rate)
        if len(self.parked) > MAX_PARKED:
            del self.parked[min(self.parked)]
            self._reject('unpaired', f'more than {MAX_PARKED} ticks waiting for their '
                                     f'magnetometer samples; the oldest dropped')

    def release(self) -> None:
        """Answer the waiting ticks that have what they waited for, in stamp order."""
        magnetic = self.magnetic
        if magnetic is None:
            return
        for stamp_ns in sorted(self.parked):
            if stamp_ns in self.parked and not magnetic.waiting_for(stamp_ns):
                attitude, rate = self.parked.pop(stamp_ns)
                self._answer(stamp_ns, attitude, rate)

    def drop_parked(self, drop: Callable[[int], bool]) -> None:
        """Forget the waiting ticks ``drop`` selects (a later tick was answered), counted
        ``no_mount`` (its sample came, its frame's mount did not) or ``unpaired``."""
        for stamp in [stamp for stamp in self.parked if drop(stamp)]:
            del self.parked[stamp]
            if self.magnetic is not None and self.magnetic.lacks_mount(stamp):
                self._reject('no_mount', 'a tick whose magnetometer sample is in a frame '
                                         'without a mount on /tf_static (or parameter '
                                         '`magnetometer_mount_rpy`) before a later tick was '
                                         'answered')
            else:
                self._reject('unpaired', 'a tick whose magnetometer sample (or wheel state) '
                                         'never came before a later tick was answered')

    def count_dropped_inputs(self) -> None:
        """Count the magnetic inputs the last answer dropped unused (``stale_stamp``)."""
        magnetic = self.magnetic
        if magnetic is not None and magnetic.refusals:
            for reason, text in magnetic.refusals:
                self._reject(reason, text)
            magnetic.refusals.clear()
