"""Quality of service of the node's inputs and outputs."""

from rclpy.qos import qos_profile_sensor_data, QoSProfile

__all__ = ['INPUT_QOS', 'OUTPUT_QOS']

#: Inputs: best effort (receives from best-effort and reliable publishers), keep last 5.
INPUT_QOS = qos_profile_sensor_data
#: Outputs: reliable, keep last 10 (reaches reliable and best-effort subscribers).
OUTPUT_QOS = QoSProfile(depth=10)
