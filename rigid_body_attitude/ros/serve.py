"""Serving the node: :func:`main` (the ``propagation_node`` executable) and :func:`spin`.

Gyro scenes are served by a :class:`~rigid_body_attitude.ros.gyro_loop.GyroLoop` on the main
thread (gyro messages and timers) and a ``SingleThreadedExecutor`` in a second thread for the
rest (parameter services, ``~/reset``, ``set_pose``), which then sleeps in ``rcl_wait`` (GIL
released) nearly all the time; :attr:`AttitudePropagatorNode.state_lock` keeps the two threads'
changes of the state apart. Dynamics scenes are served by ``rclpy.spin``. :func:`main` also
sets Fast DDS and the scheduler up for kHz rates (:mod:`rigid_body_attitude.ros.middleware`).
"""

from __future__ import annotations

import gc
import sys
import threading

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.task import Future

from rigid_body_attitude.core.errors import AttitudeError
from rigid_body_attitude.ros.gyro_loop import GyroLoop
from rigid_body_attitude.ros.middleware import apply_cpu_scheduling, use_packaged_fastdds_profile
from rigid_body_attitude.ros.node import AttitudePropagatorNode
from rigid_body_attitude.ros.rclpy_internals import RCLError

__all__ = ['main', 'spin']


def _error_text(err: BaseException) -> str:
    """The first line of an error, without rcl's source locations."""
    return str(err).splitlines()[0].split(', at /')[0] if str(err) else type(err).__name__


def _serve_rest(executor: SingleThreadedExecutor, done: Future, loop: GyroLoop,
                failures: list[BaseException]) -> None:
    """Body of the executor thread: spin until ``done`` or shutdown; a callback's exception
    stops the gyro loop too."""
    try:
        executor.spin_until_future_complete(done)
    except ExternalShutdownException:
        pass
    except BaseException as err:  # handed to the main thread, which re-raises it
        failures.append(err)
        loop.stop()


def spin(node: AttitudePropagatorNode) -> None:
    """Serve ``node`` until SIGINT or shutdown. Gyro scenes: gyro messages and timers in a
    :class:`GyroLoop` on this thread, the rest (services, parameters, set_pose) with a
    ``SingleThreadedExecutor`` in a daemon thread. Dynamics scenes: ``rclpy.spin``.

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
    loop = node.gyro_loop()  # claims the gyro subscriptions and timers before any spin
    executor = SingleThreadedExecutor(context=node.context)
    if loop is None:
        _apply_cpu_scheduling(node)
        rclpy.spin(node, executor)
        return
    executor.add_node(node)
    done, failures = Future(), []
    rest = threading.Thread(target=_serve_rest, args=(executor, done, loop, failures),
                            name='executor', daemon=True)
    try:
        rest.start()
        _apply_cpu_scheduling(node)
        loop.run()
    finally:
        if rest.ident is not None:  # started
            _stop(done, rest)
        executor.shutdown()  # only now: its thread no longer waits (rclpy issue #968)
        loop.close()
    if failures:
        raise failures[0]


def _apply_cpu_scheduling(node: AttitudePropagatorNode) -> None:
    """Give every thread of the process the node's ``cpu_scheduling`` policy; log it."""
    outcome = apply_cpu_scheduling(node.cpu_scheduling)
    if outcome.refused:
        node.get_logger().warning(
            f'cpu_scheduling {node.cpu_scheduling!r} refused by the system '
            f'({outcome.refused}); the other threads keep their policy')
    node.get_logger().info(f'cpu_scheduling {node.cpu_scheduling!r}: {outcome.changed} '
                           f'threads changed; serving')


def _stop(done: Future, thread: threading.Thread) -> None:
    """End the executor thread (``done``) and wait for it, even through KeyboardInterrupt.

    rclpy raises KeyboardInterrupt in the main thread some time after SIGINT; if it cut this
    wait short, the node would be destroyed under callbacks still running in ``thread``.
    """
    while True:
        try:
            if not done.done():
                done.set_result(None)  # wakes the executor, whose spin then returns
            thread.join()
            return
        except KeyboardInterrupt:
            continue


def main(args: list[str] | None = None) -> int:
    """Run the node until SIGINT (exit 0); bad parameters or scene: ``error: ...``, exit 2."""
    profile_note = use_packaged_fastdds_profile()  # before the participant exists
    try:
        rclpy.init(args=args)
    except RuntimeError as err:  # rcl could not parse the ROS arguments
        print(f'error: {_error_text(err)}', file=sys.stderr)
        return 2
    node = None
    try:
        node = AttitudePropagatorNode()
        node.get_logger().info(profile_note)
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
