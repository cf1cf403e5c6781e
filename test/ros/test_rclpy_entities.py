"""The interface's endpoints as rclpy entities (ros/interface.py, ros/qos.py): every type
imports, every profile name has its rclpy profile, the service profile is rclpy's default."""

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, qos_profile_services_default, ReliabilityPolicy)

from rigid_body_attitude.ros.diagnostics import LEVEL_BYTES
from rigid_body_attitude.ros.interface import interface_class
from rigid_body_attitude.ros.qos import GYRO_QOS, qos_profile
from rigid_body_attitude.session.interface import (
    CONTROLLER_INTERFACE, NODE_INTERFACE, QOS_PROFILES)
from rigid_body_attitude.session.reports import LEVEL_ERROR, LEVEL_OK, LEVEL_WARN


def test_every_endpoint_type_is_an_rclpy_interface_class():
    for endpoint in (*NODE_INTERFACE, *CONTROLLER_INTERFACE):
        cls = interface_class(endpoint.type)
        package, kind, name = endpoint.type.split('/')
        assert cls.__name__ == name and cls.__module__.startswith(f'{package}.{kind}')
        if endpoint.direction == 'service':
            assert hasattr(cls, 'Request') and hasattr(cls, 'Response')


def test_every_profile_name_gives_its_rclpy_profile():
    for name, profile in QOS_PROFILES.items():
        made = qos_profile(name)
        assert made.history == HistoryPolicy.KEEP_LAST and made.depth == profile.depth
        assert made.reliability.name.lower() == profile.reliability
        assert made.durability.name.lower() == profile.durability
    assert qos_profile('service') == qos_profile_services_default
    assert (GYRO_QOS.reliability, GYRO_QOS.durability, GYRO_QOS.depth) == (
        ReliabilityPolicy.BEST_EFFORT, DurabilityPolicy.VOLATILE, 5000)


def test_one_diagnostics_level_table_covers_every_report_level():
    assert LEVEL_BYTES == {LEVEL_OK: DiagnosticStatus.OK, LEVEL_WARN: DiagnosticStatus.WARN,
                           LEVEL_ERROR: DiagnosticStatus.ERROR}
