"""Thin rclpy adapters around the pure logic: publisher, estimator, diagnostics."""
