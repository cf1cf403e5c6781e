"""The adapter over rclpy's private binding fails here, loudly, when rclpy changes."""

import rclpy
from rclpy.clock import Clock, ClockType, ROSClock
from rclpy.time import Time
from rclpy.impl.implementation_singleton import rclpy_implementation as binding

from rigid_body_attitude.ros import rclpy_internals


def test_every_private_name_the_adapter_uses_exists() -> None:
    missing = [name for name in rclpy_internals.USED_NAMES if not hasattr(binding, name)]
    assert missing == [], f'rclpy no longer has {missing}: update ros/rclpy_internals.py'


def test_every_wait_set_method_the_gyro_loop_calls_exists() -> None:
    missing = [name for name in rclpy_internals.WAIT_SET_METHODS
               if not hasattr(binding.WaitSet, name)]
    assert missing == [], f'rclpy WaitSet no longer has {missing}: update ros/gyro_loop.py'


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
    steady = Clock(clock_type=ClockType.STEADY_TIME)
    read = rclpy_internals.clock_nanoseconds(steady)
    before = steady.now().nanoseconds
    value = read()
    after = steady.now().nanoseconds
    assert isinstance(value, int) and before <= value <= after
    ros_clock = ROSClock()
    read = rclpy_internals.clock_nanoseconds(ros_clock)
    ros_clock._set_ros_time_is_active(True)
    ros_clock.set_ros_time_override(Time(seconds=12, nanoseconds=345))
    assert read() == 12_000_000_345
