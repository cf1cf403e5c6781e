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

When the scene's ``magnetorquers`` take commands, a lockstep plant also waits for a ``dipole``
each tick: the controller answers it with the same stamp, zero (the rods idle; momentum the
wheels gather stays in them).
"""

from __future__ import annotations

from collections.abc import Callable

from rigid_body_attitude.core.control.allocation import wheel_torques
from rigid_body_attitude.core.dynamics.effects.magnetorquers import Magnetorquers
from rigid_body_attitude.core.dynamics.effects.reaction_wheels import ReactionWheels
from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.yaml_files import quote
from rigid_body_attitude.msgs.cdr import encode_vector3_stamped
from rigid_body_attitude.msgs.joint_state import joint_state_encoder

__all__ = ['WheelDrive']

Vector = tuple[float, float, float]
_ZERO: Vector = (0.0, 0.0, 0.0)


class WheelDrive:
    """A scene's wheel array driven by body torques; the rods' dipole answered when asked."""

    def __init__(self, scene: Scene, body_frame: str) -> None:
        """The array of ``scene`` (SceneError naming the scene when it has none)."""
        effects = scene.build_effects()
        wheels = next((e for e in effects if isinstance(e, ReactionWheels)), None)
        if wheels is None:
            raise SceneError(f'Expected scene {quote(scene.name)} to have reaction_wheels '
                             f'(parameter `actuator` reaction_wheels), got none')
        self.names = wheels.names
        self.allocation = wheels.allocation
        self.body_frame = body_frame
        self._encode = joint_state_encoder('', self.names)
        #: Whether the plant takes a ``dipole`` command every tick (commanded rods).
        self.answers_dipole = any(isinstance(e, Magnetorquers) and 'dipole' in e.input_names
                                  for e in effects)
        #: The last motor torques sent [N m], in :attr:`names` order.
        self.torques: tuple[float, ...] = (0.0,) * len(self.names)

    def answer(self, sec: int, nanosec: int, torque_body: Vector,
               publish_wheels: Callable[[bytes], None],
               publish_dipole: Callable[[bytes], None]) -> None:
        """The wheels' JointState for ``torque_body`` [N m] and, when the plant waits for
        one, the zero dipole, both stamped ``(sec, nanosec)``."""
        self.torques = wheel_torques(self.allocation, torque_body)
        publish_wheels(self._encode(sec, nanosec, (), (), self.torques))
        if self.answers_dipole:
            publish_dipole(encode_vector3_stamped(sec * 1_000_000_000 + nanosec,
                                                  self.body_frame, _ZERO))
