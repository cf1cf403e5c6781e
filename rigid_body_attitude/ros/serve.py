"""Serving the node: :func:`main` (the ``propagation_node`` executable) and :func:`spin`.

Every scene is served by a :class:`~rigid_body_attitude.ros.raw_take_loop.RawTakeLoop` on the main
thread (gyro messages, if any, and the two timers) and a ``SingleThreadedExecutor`` in a second
thread for the rest (parameter services, ``~/reset``, ``set_pose``, commands), which then
sleeps in ``rcl_wait`` (GIL released) nearly all the time;
:attr:`AttitudePropagatorNode.state_lock` keeps the two threads' changes of the state apart.
:func:`main` also sets Fast DDS up (:mod:`rigid_body_attitude.ros.middleware`); threads keep
the scheduling policy and CPUs the process was started with (``chrt``, ``taskset``). That
fast path uses rclpy's private parts (:mod:`~rigid_body_attitude.ros.rclpy_internals`); without
them, rclpy's stock executor serves every entity on the main thread instead (one log line says
so), except a scene on its own sim clock (``publish_clock``, ``lockstep``), whose step loop
needs the fast path: the node then stops with one ``error:`` line.
"""

from __future__ import annotations

from collections.abc import Callable
import gc
import sys
import threading

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import uninstall_signal_handlers

from rigid_body_attitude.console import closed_pipe_safe
from rigid_body_attitude.core.errors import AttitudeError, InputError
from rigid_body_attitude.ros.cli_help import node_parameter_rows, usage_text, wants_help
from rigid_body_attitude.ros.raw_take_loop import RawTakeLoop
from rigid_body_attitude.ros.middleware import use_packaged_fastdds_profile
from rigid_body_attitude.ros.node import AttitudePropagatorNode
from rigid_body_attitude.ros.rclpy_internals import fast_path_problem, RCLError

__all__ = ['SERVING_LINE', 'error_text', 'main', 'run_executable', 'serve_beside_executor',
           'spin']

#: The log line after which the node serves its topics (the last of the start-up).
SERVING_LINE = 'serving'


def error_text(err: BaseException) -> str:
    """The first line of an error, without rcl's source locations."""
    return str(err).splitlines()[0].split(', at /')[0] if str(err) else type(err).__name__


class _ExecutorThread:
    """The executor serving the rest of the node, in a thread of its own, until :meth:`stop`.

    It calls ``executor.spin_once()`` until stopped; :meth:`stop` sets a flag and triggers a
    guard condition of the node, whose (empty) callback makes the pending ``spin_once``
    return. Not ``spin_until_future_complete`` on a future done at shutdown: rclpy 7.1.6 adds
    a done-callback to that future on every wake-up (ros2/rclpy#1371), so the process grew by
    about 280 bytes per ``set_pose`` message, parameter set or service call. Nor
    ``executor.shutdown()`` from the other thread: it destroys the guard conditions of a wait
    set that may still be waiting (rclpy issue #968).
    """

    def __init__(self, executor: SingleThreadedExecutor, node: Node, loop: RawTakeLoop) -> None:
        """Serve ``node``'s remaining entities with ``executor``; stop ``loop`` on failure."""
        self.executor, self.node, self.loop = executor, node, loop
        self.failures: list[BaseException] = []
        self._stopping = threading.Event()
        self._stop_guard = node.create_guard_condition(_nothing)
        self.thread = threading.Thread(target=self._serve, name='executor', daemon=True)

    def _serve(self) -> None:
        """Thread body: spin until stopped or shutdown; a callback's exception stops the gyro
        loop too (the main thread re-raises it)."""
        try:
            while not self._stopping.is_set() and self.executor.context.ok():
                self.executor.spin_once()
        except ExternalShutdownException:
            pass
        except BaseException as err:  # handed to the main thread, which re-raises it
            self.failures.append(err)
            self.loop.stop()

    def stop(self) -> None:
        """End the thread and wait for it, even through KeyboardInterrupt.

        rclpy raises KeyboardInterrupt in the main thread some time after SIGINT; if it cut
        this wait short, the node would be destroyed under callbacks still running in the
        thread.
        """
        while True:
            try:
                if self.thread.ident is not None:  # started
                    self._stopping.set()
                    self._stop_guard.trigger()
                    self.thread.join()
                self.node.destroy_guard_condition(self._stop_guard)
                return
            except KeyboardInterrupt:
                continue


def _nothing() -> None:
    """The stop guard's callback: running it is what makes ``spin_once`` return."""


def spin(node: AttitudePropagatorNode) -> None:
    """Serve ``node`` until SIGINT or shutdown: gyro messages (gyro scenes) and timers in a
    :class:`RawTakeLoop` on this thread, the rest (services, parameters, set_pose, commands) with
    a ``SingleThreadedExecutor`` in a daemon thread.

    An exception of a callback in either thread ends both and propagates. Before serving,
    the objects of the start-up (rclpy, NumPy, SciPy, the scene) are collected once and
    frozen out of the garbage collector's reach: a full collection would otherwise scan them
    all and delay dozens of gyro messages at once; afterwards it scans only what the run
    itself keeps. Everything that serves is built before the node logs :data:`SERVING_LINE`:
    a KeyboardInterrupt inside an rclpy constructor would leave a half-built object whose
    finaliser fails at exit, so after that line a Ctrl-C always exits cleanly.
    """
    gc.collect()
    gc.freeze()
    problem = fast_path_problem()
    if problem is not None:
        if node.built.sim_clock is not None:
            raise InputError(f'publish_clock and lockstep need the node\'s own step loop, '
                             f'which rclpy\'s stock executor cannot serve ({problem}); run '
                             f'without them on this path')
        _spin_stock(node, problem)
        return
    # Claims the gyro subscriptions and the timers before any executor spins.
    serve_beside_executor(node, node.serving_loop())


def serve_beside_executor(node: Node, loop: RawTakeLoop) -> None:
    """Run ``loop`` on this thread and serve the rest of ``node`` (services, parameters) with
    a ``SingleThreadedExecutor`` in a daemon thread, until SIGINT or shutdown; logs
    :data:`SERVING_LINE` once both serve. An exception of a callback in either thread ends
    both and propagates."""
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    rest = _ExecutorThread(executor, node, loop)
    try:
        rest.thread.start()
        node.get_logger().info(SERVING_LINE)
        loop.run()
    finally:
        # rclpy's signal thread triggers every SIGINT guard condition (the loop's, the
        # executor's) some time after the signal; on a loaded machine it ran after they were
        # destroyed here: a segfault in rcl_trigger_guard_condition (seen in a core dump).
        # Uninstalling the handlers joins that thread first.
        uninstall_signal_handlers()
        rest.stop()
        executor.shutdown()  # after the join: its thread no longer waits (rclpy issue #968)
        loop.close()
    if rest.failures:
        raise rest.failures[0]


def _spin_stock(node: AttitudePropagatorNode, problem: str) -> None:
    """Serve every entity of ``node`` with rclpy's stock ``SingleThreadedExecutor`` on this
    thread, public calls only (:mod:`~.rclpy_internals`: the fast path's private names are
    missing, or the environment asks for this path)."""
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    logger = node.get_logger()
    logger.warning(f"serving with rclpy's stock executor ({problem}): the same topics, at a "
                   'higher CPU cost per message (docs/performance.md)')
    logger.info(SERVING_LINE)
    try:
        executor.spin()
    finally:
        executor.shutdown()


def run_executable(args: list[str] | None, usage: Callable[[], str],
                   build: Callable[[], Node], serve: Callable[[Node], None]) -> int:
    """The body of every executable's ``main``: ``-h``/``--help`` prints ``usage()`` before
    anything of ROS starts (exit 0); otherwise rclpy starts with the packaged Fast DDS
    profile, ``build()`` makes the node and ``serve(node)`` serves it until SIGINT (exit 0).
    Bad ROS arguments, parameters or scene: one ``error: ...`` line, exit 2.

    ``args`` as ``sys.argv`` (program name first; default ``sys.argv``).
    """
    if wants_help((sys.argv if args is None else args)[1:]):
        print(usage())
        return 0
    middleware_note = use_packaged_fastdds_profile()  # before the participant exists
    try:
        rclpy.init(args=args)
    except RuntimeError as err:  # rcl could not parse the ROS arguments
        print(f'error: {error_text(err)}', file=sys.stderr)
        return 2
    node = None
    try:
        node = build()
        node.get_logger().info(middleware_note)
        serve(node)
    except (AttitudeError, ParameterException, OSError) as err:
        print(f'error: {error_text(err)}', file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RCLError:
        # SIGINT shut the context down while a message was being taken or published.
        if rclpy.ok():
            raise
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


@closed_pipe_safe
def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT (exit 0); bad parameters or scene: ``error: ...``, exit 2
    (:func:`run_executable`)."""
    return run_executable(args, lambda: usage_text(node_parameter_rows()),
                          AttitudePropagatorNode, _spin_any)


def _spin_any(node: Node) -> None:
    """:func:`spin` for the propagation node."""
    assert isinstance(node, AttitudePropagatorNode)
    spin(node)


if __name__ == '__main__':
    sys.exit(main())
