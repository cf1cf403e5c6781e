"""The adapter over rclpy's private parts fails here, loudly, when rclpy changes; and the node
still serves its topics on rclpy's stock executor when those parts are missing."""

import types

import rclpy
from rclpy.clock import Clock, ClockType, ROSClock
from rclpy.time import Time
from rclpy.impl.implementation_singleton import rclpy_implementation as binding

from rigid_body_attitude.ros import rclpy_internals


def test_every_private_name_the_fast_path_uses_exists() -> None:
    missing = rclpy_internals.missing_private_names()
    assert missing == [], f'rclpy no longer has {missing}: update ros/rclpy_internals.py'


def test_the_listed_names_are_all_the_fast_path_uses() -> None:
    """The list the check walks: the binding's wait set, error type, take, raw publish, timer
    and clock calls, and the ``handle`` of six rclpy classes."""
    assert set(rclpy_internals.BINDING_METHODS) == {
        'WaitSet', 'RCLError', 'Subscription', 'Publisher', 'Timer', 'Clock'}
    assert rclpy_internals.BINDING_METHODS['WaitSet'] == rclpy_internals.WAIT_SET_METHODS
    assert {owner.__name__ for owner in rclpy_internals.HANDLE_OWNERS} == {
        'Context', 'Subscription', 'Publisher', 'Timer', 'GuardCondition', 'Clock'}
    for name, methods in rclpy_internals.BINDING_METHODS.items():
        assert all(hasattr(getattr(binding, name), method) for method in methods), name


def test_a_binding_without_a_name_is_reported_missing() -> None:
    """What a future rclpy that moved a name looks like to the check."""
    partial = types.SimpleNamespace(**{name: getattr(binding, name)
                                       for name in rclpy_internals.BINDING_METHODS
                                       if name != 'WaitSet'})
    assert rclpy_internals.missing_private_names(partial) == ['WaitSet']
    no_take = types.SimpleNamespace(**{**vars(partial), 'WaitSet': binding.WaitSet,
                                       'Subscription': object})
    assert rclpy_internals.missing_private_names(no_take) == ['Subscription.take_message']

    class Handleless:
        pass
    assert rclpy_internals.missing_private_names(binding, (Handleless,)) == [
        'Handleless.handle']


def test_the_environment_can_ask_for_the_stock_executor(monkeypatch) -> None:
    rclpy_internals.fast_path_problem.cache_clear()
    monkeypatch.setenv(rclpy_internals.STOCK_EXECUTOR_VARIABLE, '1')
    try:
        assert rclpy_internals.fast_path_problem() == (
            f'{rclpy_internals.STOCK_EXECUTOR_VARIABLE}=1')
        monkeypatch.delenv(rclpy_internals.STOCK_EXECUTOR_VARIABLE)
        rclpy_internals.fast_path_problem.cache_clear()
        assert rclpy_internals.fast_path_problem() is None
    finally:
        rclpy_internals.fast_path_problem.cache_clear()


def test_rcl_error_is_an_exception_type() -> None:
    assert issubclass(rclpy_internals.RCLError, Exception)


def test_new_wait_set_holds_and_clears_entities(ros_domain_id: int) -> None:
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        wait_set = rclpy_internals.new_wait_set(context, 1, 2, 1)
        wait_set.clear_entities()
        wait_set.wait(0)  # an empty wait set returns at once (timeout 0)
        wait_set.destroy_when_not_in_use()
    finally:
        rclpy.shutdown(context=context)


def test_clock_nanoseconds_reads_the_clock_and_its_ros_time_override() -> None:
    for fast in (True, False):
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        read = rclpy_internals.clock_nanoseconds(steady, fast)
        before = steady.now().nanoseconds
        value = read()
        after = steady.now().nanoseconds
        assert isinstance(value, int) and before <= value <= after
        ros_clock = ROSClock()
        read = rclpy_internals.clock_nanoseconds(ros_clock, fast)
        ros_clock._set_ros_time_is_active(True)
        ros_clock.set_ros_time_override(Time(seconds=12, nanoseconds=345))
        assert read() == 12_000_000_345
