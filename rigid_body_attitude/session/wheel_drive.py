"""``attitude_controller`` driving a reaction-wheel array: its body torque over the wheels.

With ``actuator`` ``reaction_wheels`` the controller reads its array from the scene the plant
runs (the ``scene`` parameter: a built-in name or a file, as the propagation node takes it):
the ``reaction_wheels`` effect's ``names`` and spin axes. Each tick's body torque ``τ_c`` (the
PD law's, clipped to ``torque_limit``) becomes the motor torques ``τₘ = −A⁺ τ_c``
(:func:`~rigid_body_attitude.core.control.allocation.wheel_torques`: the minimum-norm
pseudo-inverse of the axes, the same allocation an ``attitude_pd`` of the scene with
``actuator: reaction_wheels`` makes), published as one ``sensor_msgs/msg/JointState``
(``name`` the wheels, ``effort`` the torques [N m]) stamped like the tick it answers. The
wheels' own limits are the plant's: it clips each torque to ``max_torque`` and cuts it at
``max_speed``.

When the scene's ``magnetorquers`` take commands (:attr:`WheelDrive.answers_dipole`), a
lockstep plant also waits for a ``dipole`` each tick: the controller answers it with the same
stamp, zero (the rods idle; momentum the wheels gather stays in them) or, with a
``dumping_gain``, the dipole dumping the wheels' stored momentum ``h_w = Σ Jₛᵢ Ωᵢ âᵢ``
(:meth:`WheelDrive.stored_momentum`, from the speeds the plant's ``wheels/state`` reports;
:mod:`~rigid_body_attitude.session.magnetic_control`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

from rigid_body_attitude.core.control.allocation import wheel_torques
from rigid_body_attitude.core.dynamics.effects.magnetorquers import Magnetorquers
from rigid_body_attitude.core.dynamics.effects.reaction_wheels import ReactionWheels
from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.yaml_files import quote
from rigid_body_attitude.msgs.joint_state import joint_state_encoder

__all__ = ['WheelDrive', 'commanded_rods']

Vector = tuple[float, float, float]


class WheelDrive:
    """A scene's wheel array driven by body torques; whether its rods take a dipole."""

    def __init__(self, scene: Scene) -> None:
        """The array of ``scene`` (SceneError naming the scene when it has none)."""
        effects = scene.build_effects()
        wheels = next((e for e in effects if isinstance(e, ReactionWheels)), None)
        if wheels is None:
            raise SceneError(f'Expected scene {quote(scene.name)} to have reaction_wheels '
                             f'(parameter `actuator` reaction_wheels), got none')
        self.names = wheels.names
        self.allocation = wheels.allocation
        #: Each wheel's spin axis (body, unit) and spin inertia [kg m²], in :attr:`names` order.
        self.axes: tuple[tuple[float, float, float], ...] = tuple(
            (float(a), float(b), float(c)) for a, b, c in wheels.axes)
        self.spin_inertia = tuple(float(j) for j in wheels.wheel['spin_inertia'])
        self._encode = joint_state_encoder('', self.names)
        #: Whether the plant takes a ``dipole`` command every tick (commanded rods).
        self.answers_dipole = commanded_rods(effects)
        #: The last motor torques sent [N m], in :attr:`names` order.
        self.torques: tuple[float, ...] = (0.0,) * len(self.names)

    def answer(self, sec: int, nanosec: int, torque_body: Vector,
               publish_wheels: Callable[[bytes], None]) -> None:
        """The wheels' JointState for ``torque_body`` [N m], stamped ``(sec, nanosec)``."""
        self.torques = wheel_torques(self.allocation, torque_body)
        publish_wheels(self._encode(sec, nanosec, (), (), self.torques))

    def stored_momentum(self, speeds: Sequence[float]) -> Vector:
        """``h_w = Σ Jₛᵢ Ωᵢ âᵢ`` [N m s, body] of the speeds relative to the body ``speeds``
        [rad/s] (in :attr:`names` order)."""
        x = y = z = 0.0
        for (a, b, c), j, speed in zip(self.axes, self.spin_inertia, speeds):
            x, y, z = x + j * speed * a, y + j * speed * b, z + j * speed * c
        return x, y, z


def commanded_rods(effects: Iterable[object]) -> bool:
    """Whether ``effects`` hold magnetorquers that take a ``dipole`` command."""
    return any(isinstance(e, Magnetorquers) and 'dipole' in e.input_names for e in effects)
