"""``/diagnostics`` of the package's nodes: one publisher class, one level table.

The propagation nodes (:class:`~.outputs.RosOutputs`) and ``attitude_controller`` publish their
sessions' :class:`~rigid_body_attitude.session.reports.DiagnosticReport` through a
:class:`DiagnosticsPublisher`: one ``diagnostic_msgs/DiagnosticStatus`` named after the node
(its fully qualified name), stamped with the node clock, on the interface's ``/diagnostics``
(:mod:`rigid_body_attitude.session.interface`).
"""

from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

from rigid_body_attitude.ros.interface import create_publisher
from rigid_body_attitude.session.interface import Interface
from rigid_body_attitude.session.reports import (
    DiagnosticReport, LEVEL_ERROR, LEVEL_OK, LEVEL_WARN)

__all__ = ['DiagnosticsPublisher', 'LEVEL_BYTES']

#: The sessions' report levels → ``DiagnosticStatus`` levels.
LEVEL_BYTES = {LEVEL_OK: DiagnosticStatus.OK, LEVEL_WARN: DiagnosticStatus.WARN,
               LEVEL_ERROR: DiagnosticStatus.ERROR}


class DiagnosticsPublisher:
    """``/diagnostics`` of one node (the endpoint of its ``interface``)."""

    def __init__(self, node: Node, interface: Interface, hardware_id: str = '') -> None:
        """The publisher on ``node``; ``hardware_id``: the statuses' (settable later)."""
        self.node = node
        self.hardware_id = hardware_id
        self.publisher = create_publisher(node, interface.endpoint('/diagnostics', 'out'))

    def publish(self, report: DiagnosticReport) -> None:
        """One status of ``report``, stamped with the node clock."""
        node = self.node
        status = DiagnosticStatus(
            level=LEVEL_BYTES[report.level], name=node.get_fully_qualified_name(),
            message=report.message, hardware_id=self.hardware_id,
            values=[KeyValue(key=key, value=value) for key, value in report.values])
        array = DiagnosticArray(status=[status])
        array.header.stamp = node.get_clock().now().to_msg()
        self.publisher.publish(array)
