"""The only subpackage that imports rclpy: the node, its gyro loop and its middleware set-up."""
