"""What the nodes count as a clean stop (gear_phm.nodes.common.stopped_by_signal)."""
from __future__ import annotations


def test_stopped_by_signal_only_for_signals_and_a_shut_down_context() -> None:
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from std_msgs.msg import String

    from gear_phm.nodes.common import stopped_by_signal

    context_error = None
    rclpy.init()
    try:
        node = rclpy.create_node('test_stopped_by_signal')
        publisher = node.create_publisher(String, 'test_stopped_by_signal', 10)
        assert not stopped_by_signal(RuntimeError('a real failure while running'))
        rclpy.shutdown()                 # what rclpy's SIGINT/SIGTERM handler does
        try:
            publisher.publish(String())  # a timer callback that was just publishing
        except Exception as exc:  # noqa: BLE001 the error rclpy raises is what is tested
            context_error = exc
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    assert context_error is not None, 'publish on a shut-down context did not raise'
    assert stopped_by_signal(context_error)
    assert stopped_by_signal(KeyboardInterrupt())
    assert stopped_by_signal(ExternalShutdownException())
    assert not stopped_by_signal(ValueError('bad data'))       # not a RuntimeError
