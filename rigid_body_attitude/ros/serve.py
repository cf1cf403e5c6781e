"""Serving the node: :func:`main` (the ``propagation_node`` executable) and :func:`spin`.

Every scene is served by a :class:`~rigid_body_attitude.ros.gyro_loop.GyroLoop` on the main
thread (gyro messages, if any, and the two timers) and a ``SingleThreadedExecutor`` in a second
thread for the rest (parameter services, ``~/reset``, ``set_pose``, commands), which then
sleeps in ``rcl_wait`` (GIL released) nearly all the time;
:attr:`AttitudePropagatorNode.state_lock` keeps the two threads' changes of the state apart.
:func:`main` also
sets Fast DDS and the scheduler up for kHz rates (:mod:`rigid_body_attitude.ros.middleware`).
"""

from __future__ import annotations

from collections.abc import Callable
import gc
import platform
import sys
import threading

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.timer import Timer

from rigid_body_attitude.core.errors import AttitudeError
from rigid_body_attitude.ros.cli_help import node_parameter_rows, usage_text, wants_help
from rigid_body_attitude.ros.cpu_split import cpu_split, CpuSplit
from rigid_body_attitude.ros.gyro_loop import GyroLoop
from rigid_body_attitude.ros.middleware import (
    apply_cpu_scheduling, CPU_SCHEDULING, use_asynchronous_publication,
    use_packaged_fastdds_profile)
from rigid_body_attitude.ros.node import AttitudePropagatorNode
from rigid_body_attitude.ros.rclpy_internals import RCLError
from rigid_body_attitude.ros.sender_threads import (
    GUARD_PERIOD, GuardNote, sender_guard, sender_thread_ids, SenderGuard)
from rigid_body_attitude.ros.time_slices import (
    kernel_takes_slices, SENDER_SLICE_NS, shorten_slices)

__all__ = ['main', 'spin']


def _error_text(err: BaseException) -> str:
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

    def __init__(self, executor: SingleThreadedExecutor, node: AttitudePropagatorNode,
                 loop: GyroLoop) -> None:
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
    :class:`GyroLoop` on this thread, the rest (services, parameters, set_pose, commands) with
    a ``SingleThreadedExecutor`` in a daemon thread.

    An exception of a callback in either thread ends both and propagates. Before serving,
    the objects of the start-up (about 60 000: rclpy, NumPy, SciPy, the scene) are collected
    once and frozen out of the garbage collector's reach: a full collection would otherwise
    scan them all (35 ms here, so dozens of gyro messages delayed at once); afterwards it
    scans only what the run itself keeps. Everything that serves is built before the node's
    threads take the ``cpu_scheduling`` policy
    (:func:`~rigid_body_attitude.ros.middleware.apply_cpu_scheduling`) and the node logs it: a
    KeyboardInterrupt inside an rclpy constructor would leave a half-built object whose
    finaliser fails at exit, so after that line a Ctrl-C always exits cleanly.
    """
    gc.collect()
    gc.freeze()
    loop: GyroLoop | None = None  # built with the guard's timer, so read through a closure

    def gyro_messages() -> int:
        return 0 if loop is None else loop.handled
    guard, sender_remark = _sender_rule(node, gyro_messages)
    split, split_remark = _split_rule(node, gyro_messages)
    guards = [rule.check for rule in (guard, split) if rule is not None]
    # Claims the gyro subscriptions and the timers before any executor spins.
    loop = node.gyro_loop([_guard_timer(node, check) for check in guards])
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    rest = _ExecutorThread(executor, node, loop)
    try:
        rest.thread.start()
        _apply_cpu_scheduling(node, (sender_remark, split_remark))
        loop.run()
    finally:
        rest.stop()
        executor.shutdown()  # only now: its thread no longer waits (rclpy issue #968)
        loop.close()
    if rest.failures:
        raise rest.failures[0]


def _guard_timer(node: AttitudePropagatorNode, guard: Callable[[], list[GuardNote]]) -> Timer:
    """A steady-clock timer in the gyro loop's group calling ``guard`` every
    :data:`GUARD_PERIOD` seconds; the moves it notes are logged (warnings as warnings)."""
    def check() -> None:
        for note in guard():  # one call site per severity, as rclpy's logger wants
            if note.warning:
                node.get_logger().warning(note.text)
            else:
                node.get_logger().info(note.text)
    return node.create_timer(GUARD_PERIOD, check, node.loop_group,
                             clock=Clock(clock_type=ClockType.STEADY_TIME))


def _sender_rule(node: AttitudePropagatorNode,
                 gyro_messages: Callable[[], int]) -> tuple[SenderGuard | None, str]:
    """What ``cpu_scheduling`` ``batch`` does with Fast DDS's sender threads, and the remark
    for the start-up line: short time slices, given now (``sched_setscheduler`` keeps them);
    or, with ``idle_senders_above_hz`` set, a guard for the idle rule (gyro scenes only)."""
    if not CPU_SCHEDULING[node.cpu_scheduling].sender_rule:
        return None, ''
    if node.idle_senders_above_hz <= 0.0:
        return None, _short_sender_slices()
    if node.is_dynamics:
        return None, ''
    return sender_guard(gyro_messages, node.idle_senders_above_hz)


def _split_rule(node: AttitudePropagatorNode,
                gyro_messages: Callable[[], int]) -> tuple[CpuSplit | None, str]:
    """With ``cpu_scheduling`` ``batch`` and ``separate_cpus_above_hz`` set, in a gyro scene:
    the rule keeping the gyro loop (this thread) and the sender threads on different CPUs
    while the gyro rate is high (:mod:`~.cpu_split`), and the remark for the start-up line."""
    if (not CPU_SCHEDULING[node.cpu_scheduling].sender_rule
            or node.separate_cpus_above_hz <= 0.0 or node.is_dynamics):
        return None, ''
    return cpu_split(threading.get_native_id(), gyro_messages, node.separate_cpus_above_hz)


def _apply_cpu_scheduling(node: AttitudePropagatorNode, remarks: tuple[str, ...]) -> None:
    """Give every thread of the process the node's ``cpu_scheduling`` policy; log it with
    the ``remarks`` that are not empty (the sender rules')."""
    outcome = apply_cpu_scheduling(node.cpu_scheduling)
    logger = node.get_logger()
    if outcome.refused:
        logger.warning(
            f'cpu_scheduling {node.cpu_scheduling!r} refused by the system '
            f'({outcome.refused}); the other threads keep their policy')
    remark = ''.join(f'; {text}' for text in remarks if text)
    logger.info(f'cpu_scheduling {node.cpu_scheduling!r}: {outcome.changed} threads changed'
                f'{remark}; serving')


def _short_sender_slices() -> str:
    """Give the sender threads :data:`~.time_slices.SENDER_SLICE_NS` slices; the remark for
    the start-up line (``''`` with synchronous publication: no senders)."""
    thread_ids = sender_thread_ids()
    if not thread_ids:
        return ''
    if not kernel_takes_slices():
        return (f'Fast DDS sender threads on SCHED_BATCH (this kernel, {platform.release()}, '
                f'has no custom time slices; see idle_senders_above_hz)')
    shortened = shorten_slices(thread_ids)
    return (f'Fast DDS sender threads {shortened} on SCHED_BATCH with '
            f'{SENDER_SLICE_NS / 1e6:g} ms time slices')


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT (exit 0); bad parameters or scene: ``error: ...``, exit 2.

    ``args`` as ``sys.argv`` (program name first; default ``sys.argv``). With ``-h`` or
    ``--help`` outside the ROS arguments it prints the parameters and returns 0 before
    anything of ROS starts.
    """
    if wants_help((sys.argv if args is None else args)[1:]):
        print(usage_text(node_parameter_rows()))
        return 0
    # Both before the participant exists.
    middleware_notes = (use_packaged_fastdds_profile(), use_asynchronous_publication())
    try:
        rclpy.init(args=args)
    except RuntimeError as err:  # rcl could not parse the ROS arguments
        print(f'error: {_error_text(err)}', file=sys.stderr)
        return 2
    node = None
    try:
        node = AttitudePropagatorNode()
        for note in middleware_notes:
            node.get_logger().info(note)
        spin(node)
    except (AttitudeError, ParameterException, OSError) as err:
        print(f'error: {_error_text(err)}', file=sys.stderr)
        return 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RCLError:
        # SIGINT shut the context down while a gyro message was being taken or published.
        if rclpy.ok():
            raise
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
