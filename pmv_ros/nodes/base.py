"""What the pmv_ros nodes share: QoS, and a lean mode for the in-process fast-time pipeline."""

from __future__ import annotations

from rclpy.event_handler import EventHandler, PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import QoSProfile

#: Every pmv_ros topic: reliable, keep-last 100. Deep enough for a fast-time
#: pipeline drained every tick, bounded in memory whatever the run length.
QOS = QoSProfile(depth=100)


class PmvNode(Node):
    """A node with the project's QoS and an optional lean mode.

    Args:
        name: node name.
        lean: for the in-process pipeline (``pmv simulate``), whose graph
            nothing outside the process can see: no parameter services, no
            /rosout publisher and no default QoS-event handlers. Each of those is an entity the
            executor re-examines on every wait; dropping them almost doubles
            the fast-time rate. Parameters still work through
            ``set_parameters`` in-process, with the same validation.
    """

    def __init__(self, name: str, *, lean: bool = False, **kwargs):
        if lean:
            kwargs.setdefault("start_parameter_services", False)
            kwargs.setdefault("enable_rosout", False)  # logs still reach the console and the log file
        super().__init__(name, **kwargs)
        self._lean = lean
        self._detached = []
        if lean:
            # rclpy's own /parameter_events publisher and /clock subscription
            # come with default QoS-event handlers (they log incompatible-QoS
            # warnings); in a graph private to the process they only cost time.
            for waitable in list(self.waitables):
                if isinstance(waitable, EventHandler):
                    self.remove_waitable(waitable)
                    self._detached.append(waitable)

    def destroy_node(self):
        """Destroy the node (re-attaching detached handlers first: rclpy removes them with their publisher)."""
        for waitable in self._detached:
            self.add_waitable(waitable)
        self._detached = []
        return super().destroy_node()

    def publisher(self, message_type, topic: str):
        """A publisher with the project QoS."""
        if self._lean:
            return self.create_publisher(message_type, topic, QOS,
                                         event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))
        return self.create_publisher(message_type, topic, QOS)

    def subscription(self, message_type, topic: str, callback):
        """A subscription with the project QoS."""
        if self._lean:
            return self.create_subscription(message_type, topic, callback, QOS,
                                            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        return self.create_subscription(message_type, topic, callback, QOS)
