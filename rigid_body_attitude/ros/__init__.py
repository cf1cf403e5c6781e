"""The only subpackage that imports rclpy: the nodes, their raw-take loop, the middleware."""
