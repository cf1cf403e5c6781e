"""The managed node (executable ``managed_propagation_node``): the attitude propagator as an
``rclpy.lifecycle`` node, for robots brought up by a lifecycle manager.

The node ``attitude_propagator`` with the standard ``lifecycle_msgs`` services
(``~/change_state``, ``~/get_state``, ...). It starts unconfigured, with its parameters
declared (:data:`rigid_body_attitude.session.parameters.PARAMETERS`), and behaves, once active,
as the plain node (:mod:`~.node`), whose code it shares (:class:`~.propagator_base.
PropagatorMixin`):

* ``configure`` loads the scene and the parameters and creates the session, publishers,
  subscriptions, timers and ``~/reset``. A bad parameter (one given at start that its
  declaration refused, or one the table's checks refuse) or a bad scene makes it fail with one
  ``error`` log line naming the reason; the node stays unconfigured, nothing is left built.
* ``activate`` lets the inputs through to the session and starts the output timer (dynamics
  scenes); the first input after it is a new baseline.
* ``deactivate`` stops both; the state stays as it is. Inputs arriving while the node is not
  active are not integrated: they are counted as ``rejected inactive`` in ``/diagnostics``,
  whose status says ``inactive`` (WARN), and warned about (throttled). Reactivated, the node
  goes on from the attitude it had, without integrating across the pause.
* ``cleanup`` and ``shutdown`` destroy every entity ``configure`` created and drop what it built
  (:class:`~.propagator_base.NodeParts`, one attribute).

Transitions the state machine does not have from the current state (``activate`` before
``configure``, ``configure`` twice, ...) are refused: ``ChangeState`` answers
``success: false`` and the state is unchanged (rclpy 7.1 raised from the service callback
instead, ending the process: ros2/rclpy#1209). ``publish_clock`` and ``lockstep`` are for
``propagation_node``: the managed node is served by rclpy's ``SingleThreadedExecutor``.
"""

from __future__ import annotations

from collections.abc import Callable
import sys
from typing import Any

from lifecycle_msgs.srv import ChangeState
from rclpy.executors import SingleThreadedExecutor
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.parameter import Parameter as RosParameter

from rigid_body_attitude.console import closed_pipe_safe
from rigid_body_attitude.core.errors import AttitudeError, InputError
from rigid_body_attitude.ros.cli_help import node_parameter_rows, usage_text
from rigid_body_attitude.ros.parameters import parameter_values
from rigid_body_attitude.ros.propagator_base import PropagatorMixin
from rigid_body_attitude.ros.rclpy_internals import RCLError
from rigid_body_attitude.ros.serve import error_text, run_executable, SERVING_LINE
from rigid_body_attitude.session.parameters import PARAMETERS
from rigid_body_attitude.session.reports import inactive_report
from rigid_body_attitude.session.settings import NODE_NAME

__all__ = ['ManagedPropagatorNode', 'main']

_SUCCESS, _FAILURE = TransitionCallbackReturn.SUCCESS, TransitionCallbackReturn.FAILURE


class ManagedPropagatorNode(PropagatorMixin, LifecycleNode):
    """The propagator as a lifecycle node (module docstring); keyword arguments go to
    :class:`rclpy.lifecycle.LifecycleNode`."""

    def __init__(self, **node_options: Any) -> None:
        """Declare the parameters (a value given at start that is refused is remembered:
        ``configure`` fails on it until it is set again) and refuse unknown transitions."""
        super().__init__(NODE_NAME, **node_options)
        #: Whether inputs reach the session (the node is active).
        self.active = False
        #: What configure built (``None`` while unconfigured).
        self.parts = None
        #: Parameter name → why its value given at start was refused.
        self.parameter_problems: dict[str, str] = {}
        for parameter in PARAMETERS:
            try:
                self.declare_table_parameter(parameter)
            except InputError as err:
                self.parameter_problems[parameter.name] = str(err)
                self.declare_table_parameter(parameter, ignore_override=True)
        self.add_on_set_parameters_callback(self.parameters_callback)
        self.add_post_set_parameters_callback(self.parameters_set_callback)
        refuse_unknown_transitions(self)
        self._kept: set[Any] = set()

    # -- transitions ------------------------------------------------------------------------

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Load the scene and the parameters; build the session and its entities."""
        problem = next(iter(self.parameter_problems.values()), '')
        values = parameter_values(self)
        if not problem and (values['publish_clock'] or values['lockstep']):
            problem = ('publish_clock and lockstep need propagation_node (its own step loop); '
                       'the managed node serves with rclpy\'s executor')
        if not problem:
            self._kept = set(self._entities())
            try:
                self.build(values)
            except (AttitudeError, OSError) as err:
                problem = error_text(err)
                self._release()
        if problem:
            self.get_logger().error(f'configure refused: {problem}')
            return _FAILURE
        if self.built.output_timer is not None:
            self.built.output_timer.cancel()
        self.get_logger().info('configured (inactive: activate to integrate)')
        return _SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Inputs through to the session (the next one a new baseline), output timer on."""
        parts = self.built
        with parts.state_lock:
            parts.session.resume()
            self.active = True
        if parts.output_timer is not None:
            parts.output_timer.reset()
        self.get_logger().info('active')
        return _SUCCESS

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Inputs counted and dropped, output timer off; the state kept."""
        parts = self.built
        with parts.state_lock:
            self.active = False
        if parts.output_timer is not None:
            parts.output_timer.cancel()
        self.get_logger().info('inactive: inputs are not integrated until activated')
        return _SUCCESS

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Destroy what ``configure`` built."""
        self._release()
        self.get_logger().info('cleaned up (unconfigured)')
        return _SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Destroy what ``configure`` built, if anything (finalized)."""
        self._release()
        self.get_logger().info('shut down (finalized)')
        return _SUCCESS

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        """A transition raised: destroy what was built, back to unconfigured."""
        self._release()
        self.get_logger().error('a transition failed: released everything (unconfigured)')
        return _SUCCESS

    def _entities(self) -> list[Any]:
        return [*self.publishers, *self.subscriptions, *self.timers, *self.services,
                *self.clients, *self.guards]

    def _release(self) -> None:
        """Stop the log queue, destroy every entity created since configure began, drop what
        configure built (:attr:`parts`)."""
        self.active = False
        if self.parts is not None:
            self.parts.outputs.log_queue.stop()
        destroyers: list[tuple[Callable[[Any], Any], list[Any]]] = [
            (self.destroy_publisher, list(self.publishers)),
            (self.destroy_subscription, list(self.subscriptions)),
            (self.destroy_timer, list(self.timers)),
            (self.destroy_service, list(self.services)),
            (self.destroy_client, list(self.clients)),
            (self.destroy_guard_condition, list(self.guards))]
        for destroy, entities in destroyers:
            for entity in entities:
                if entity not in self._kept:
                    destroy(entity)
        self.parts = None

    # -- callbacks --------------------------------------------------------------------------

    def gated(self, handler: Callable[[bytes], object]) -> Callable[[bytes], object]:
        """``handler`` while active (its result returned); otherwise the message is counted
        ``inactive``."""
        def gate(data: bytes) -> object:
            if self.active:
                return handler(data)
            parts = self.built
            with parts.state_lock:
                session = parts.session
                session.rejections['inactive'] += 1
                session.warn('inactive', 'input while the node is not active: not integrated '
                             '(activate it)')
            return None
        return gate

    def diagnostics_callback(self) -> None:
        """``/diagnostics``; while not active the status says ``inactive``."""
        if self.active:
            super().diagnostics_callback()
            return
        parts = self.built
        with parts.state_lock:
            parts.outputs.diagnostics(inactive_report(parts.session.report()))

    def parameters_set_callback(self, parameters: list[RosParameter]) -> None:
        """A value set again clears the problem of the one given at start."""
        for parameter in parameters:
            self.parameter_problems.pop(parameter.name, None)
        super().parameters_set_callback(parameters)

    def destroy_node(self) -> None:
        """Release what ``configure`` built, then destroy the node."""
        self._release()
        super().destroy_node()  # type: ignore[no-untyped-call]


def refuse_unknown_transitions(node: LifecycleNode) -> None:
    """Make ``node``'s ``change_state`` service answer ``success: false`` for a transition
    that the state machine does not have from its current state (rcl refuses it before any
    change: the state stays as it is), instead of raising out of the executor."""
    for service in node.services:
        if service.srv_type is ChangeState:
            service.callback = _refusing(service.callback, node)


def _refusing(callback: Callable[[Any, Any], Any], node: LifecycleNode
              ) -> Callable[[Any, Any], Any]:
    def change_state(request: Any, response: Any) -> Any:
        try:
            return callback(request, response)
        except RCLError as err:
            node.get_logger().warning(
                f'transition {request.transition.id} {request.transition.label!r} refused: '
                f'{error_text(err)}')
            response.success = False
            return response
    return change_state


@closed_pipe_safe
def main(args: list[str] | None = None) -> int:
    """Run the managed node until SIGINT (exit 0); ``-h``/``--help`` prints the parameters
    (:func:`~.serve.run_executable`)."""
    return run_executable(args, lambda: usage_text(node_parameter_rows()),
                          ManagedPropagatorNode, _serve)


def _serve(node: Node) -> None:
    """Every entity on rclpy's stock executor, from the unconfigured state on."""
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    node.get_logger().info(f'{SERVING_LINE} (unconfigured: configure, then activate)')
    executor.spin()


if __name__ == '__main__':
    sys.exit(main())
