"""A scene's spacecraft actuators as the node commands and reports them.

:class:`WheelArray` is the scene's ``reaction_wheels`` effect seen from the node: its
``wheels/command`` (``sensor_msgs/msg/JointState``, one message per array) checked and put in
the wheels' order, its ``wheels/state`` encoded every tick, and what ``/diagnostics`` says
about each wheel. :class:`MagnetorquerReport` is what ``/diagnostics`` says about the
``magnetorquers``. The effects integrate and count; nothing here changes their state.

A wheel command names every wheel of the array once, in any order, and fills exactly one of
``effort`` (motor torques [N m]: the ``wheel_torque`` input) and ``velocity`` (speeds relative
to the body [rad/s]: ``wheel_speed``, the wheels' speed servo), one value per name;
``position`` stays empty. Anything else is refused and counted by reason
(:data:`WHEEL_REASONS`): a name the array does not have or a name twice (``unknown_wheel``),
a wheel left out (``missing_wheel``), both fields, neither, or ``position`` filled
(``wheel_fields``), a field whose length is not the number of names (``wheel_lengths``). The
values are then checked as every command (non-finite, beyond 1e12) and held by the effect,
which clips them to ``max_torque`` or ``max_speed`` (counted ``torque_limit``,
``speed_command_limit``).

The state: ``name`` the wheels in the array's order, ``position`` each wheel's angle relative
to the body [rad] in [−π, π] (the trapezoidal rule on its speed), ``velocity`` its speed
relative to the body [rad/s] (what a tachometer reads), ``effort`` the motor torque [N m]
held over the step that ended at the stamp (after the torque limit and the speed-limit cut;
friction is not in it). ``header.frame_id`` is empty, as joint states are.
"""

from __future__ import annotations

from collections.abc import Sequence

from rigid_body_attitude.core.dynamics.effects.magnetorquers import Magnetorquers
from rigid_body_attitude.core.dynamics.effects.reaction_wheels import ReactionWheels
from rigid_body_attitude.core.propagator import DynamicsPropagator
from rigid_body_attitude.msgs.joint_state import joint_state_encoder
from rigid_body_attitude.msgs.untrusted import quoted

__all__ = ['MagnetorquerReport', 'WHEEL_COMMAND_TOPIC', 'WHEEL_REASONS', 'WheelArray',
           'WheelCommand']

#: The node's input topic of wheel commands (its key among the lockstep's commands).
WHEEL_COMMAND_TOPIC = 'wheels/command'
#: Why a wheel command is refused (besides the reasons of every command).
WHEEL_REASONS = ('unknown_wheel', 'missing_wheel', 'wheel_fields', 'wheel_lengths')

#: A checked wheel command: the input (``wheel_torque`` or ``wheel_speed``), the refusal
#: reason (``''``: none) with its detail, and the values in the array's order.
WheelCommand = tuple[str, str, str, tuple[float, ...]]


class WheelArray:
    """The scene's reaction-wheel array: commands in, state and diagnostics out."""

    def __init__(self, effect: ReactionWheels) -> None:
        """Serve ``effect`` (its names, in its order)."""
        self.effect = effect
        self.names = effect.names
        self._index = {name: i for i, name in enumerate(self.names)}
        self._encode = joint_state_encoder('', self.names)
        self._speed_limited_time = [0.0] * len(self.names)
        self._episodes = 0

    @classmethod
    def of(cls, propagator: DynamicsPropagator) -> WheelArray | None:
        """The array of ``propagator``'s scene, or None."""
        effect = next((e for e in propagator.effects if isinstance(e, ReactionWheels)), None)
        return None if effect is None else cls(effect)

    def command(self, names: Sequence[str], position: Sequence[float],
                velocity: Sequence[float], effort: Sequence[float]) -> WheelCommand:
        """A JointState's fields checked (module docstring), values in the array's order."""
        unknown = [name for name in names if name not in self._index]
        if unknown or len(set(names)) != len(names):
            shown = quoted(unknown[0]) if unknown else 'a name twice'
            return '', 'unknown_wheel', (f'{shown}; the wheels are '
                                         f'{", ".join(self.names)}'), ()
        if len(names) != len(self.names):
            missing = [name for name in self.names if name not in names]
            return '', 'missing_wheel', f'no value for {", ".join(missing)}', ()
        if position or bool(velocity) == bool(effort):
            return '', 'wheel_fields', ('exactly one of effort (torques) and velocity '
                                        '(speeds) must be filled, position empty; got '
                                        f'{len(position)} positions, {len(velocity)} '
                                        f'velocities, {len(effort)} efforts'), ()
        input_name, values = (('wheel_torque', effort) if effort else
                              ('wheel_speed', velocity))
        if len(values) != len(names):
            return '', 'wheel_lengths', (f'{len(values)} values for {len(names)} names'), ()
        ordered = [0.0] * len(names)
        for name, value in zip(names, values):
            ordered[self._index[name]] = value
        return input_name, '', '', tuple(ordered)

    def state(self, sec: int, nanosec: int) -> bytes:
        """The ``wheels/state`` JointState at the propagated time, stamped ``(sec, nanosec)``."""
        effect = self.effect
        return self._encode(sec, nanosec, effect.angles, effect.speeds(), effect.motor)

    def speed_limit_news(self) -> str:
        """A warning when a wheel reached its speed limit since the last call, else ``''``."""
        episodes = sum(self.effect.speed_limit_episodes)
        if episodes == self._episodes:
            return ''
        self._episodes = episodes
        cut = [name for name, cutting in zip(self.names, self.effect.cutting) if cutting]
        return (f'reaction_wheels: {", ".join(cut) or "a wheel"} at the speed limit '
                f'(max_speed): motor torque that would speed it up is cut')

    def report(self) -> tuple[list[tuple[str, str]], list[str]]:
        """The diagnostics values of every wheel, and the period's problem: wheels whose
        torque was cut at the speed limit during it (their time there)."""
        effect, values, problems = self.effect, [], []
        speeds = effect.speeds()
        for i, name in enumerate(self.names):
            values += [
                (f'{name} speed [rad/s]', f'{speeds[i]:.9g}'),
                (f'{name} motor torque [N m]', f'{effect.motor[i]:.9g}'),
                (f'{name} at speed limit [s]', f'{effect.speed_limited_time[i]:.6g}'),
                (f'{name} speed limit episodes', str(effect.speed_limit_episodes[i])),
                (f'{name} at torque limit [s]', f'{effect.torque_limited_time[i]:.6g}'),
            ]
            new = effect.speed_limited_time[i] - self._speed_limited_time[i]
            if new > 0.0:
                problems.append(f'{name} at its speed limit for {new:.3g} s of the last '
                                f'period: motor torque cut (parameter `max_speed` of '
                                f'reaction_wheels)')
        self._speed_limited_time = list(effect.speed_limited_time)
        values += [('wheels motor work [J]', f'{effect.motor_work:.9g}'),
                   ('wheels friction loss [J]', f'{effect.friction_loss:.9g}')]
        return values, problems


class MagnetorquerReport:
    """What ``/diagnostics`` says about the scene's torque rods."""

    def __init__(self, effect: Magnetorquers) -> None:
        """Report ``effect``."""
        self.effect = effect

    @classmethod
    def of(cls, propagator: DynamicsPropagator) -> MagnetorquerReport | None:
        """The rods of ``propagator``'s scene, or None."""
        effect = next((e for e in propagator.effects if isinstance(e, Magnetorquers)), None)
        return None if effect is None else cls(effect)

    def values(self) -> list[tuple[str, str]]:
        """The dipole the rods give [A m², body] and the torque impulse so far [N m s]."""
        return [('magnetorquers dipole [A m2]',
                 ' '.join(f'{value:.9g}' for value in self.effect.dipole)),
                ('magnetorquers torque impulse [N m s]',
                 f'{self.effect.torque_impulse:.9g}')]
