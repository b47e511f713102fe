"""The sensor's transforms on ``/tf`` and ``/tf_static``, when ``tf2_msgs`` is there.

``tf2_msgs`` is not on the package registries (users have it from their ROS 2
install), so it is imported here only, and its absence is a state, not an
error: :func:`tf_message_type` is None, the sensor says so once at start-up
and publishes no transforms; everything else runs as before.

Published (interfaces.md "Topics", /tf and /tf_static):

* ``/tf_static``, once, reliable and transient local (a late listener gets
  it): ``base_link → pmv_sensor``, the mounting;
* ``/tf`` with every sample: ``eci → orbital`` (the orbit: the same pose as
  /orbit/odometry) and, with the sensor's own attitude model only,
  ``orbital → base_link`` (the attitude of /attitude/truth). In follow mode
  the user's stack owns the attitude and that transform.
"""

from __future__ import annotations

from geometry_msgs.msg import TransformStamped
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

import pmv_msgs_shim as shim
from ..runtime.common.frames import Frames

#: /tf: as tf2_ros's TransformBroadcaster (reliable, volatile, keep-last 100).
TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
#: /tf_static: as tf2_ros's StaticTransformBroadcaster (reliable, transient local, keep-last 1).
TF_STATIC_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)

#: What the sensor logs once at start-up when it cannot publish transforms.
NO_TF2_MSGS = ("tf2_msgs cannot be imported (it comes with a ROS 2 install, not from the package registries): "
               "no /tf or /tf_static from this node; every other topic is published as usual")

_ORIGIN = (0.0, 0.0, 0.0)


def tf_message_type():
    """``tf2_msgs.msg.TFMessage``, or None when tf2_msgs cannot be imported."""
    try:
        from tf2_msgs.msg import TFMessage
    except ImportError:
        return None
    return TFMessage


class SensorTransforms:
    """The sensor node's transform publishers: the static mounting once, the orbit (and attitude) per sample.

    Args:
        node: the sensor node (publishers are made on it).
        message_type: ``TFMessage`` (:func:`tf_message_type`).
        frames: the spacecraft's frame ids.
        q_body_to_sensor: the mounting, (x, y, z, w).
        own_attitude: publish ``orbital → base_link`` (the sensor's own attitude model).
        stamp_s: stamp of the static transform, s (the node clock at start-up).
    """

    def __init__(self, node, message_type, frames: Frames, q_body_to_sensor, own_attitude: bool, stamp_s: float):
        self._frames, self._own_attitude = frames, own_attitude
        self._static = node.create_publisher(message_type, "/tf_static", TF_STATIC_QOS)
        self._dynamic = node.create_publisher(message_type, "/tf", TF_QOS)
        mounting = shim.write_transform(TransformStamped(), max(stamp_s, 0.0), frames.base_link, frames.sensor,
                                        _ORIGIN, q_body_to_sensor)
        self._static.publish(message_type(transforms=[mounting]))
        # One message filled in place for every sample (rclpy serialises at publish).
        self._orbital, self._body = TransformStamped(), TransformStamped()
        self._out = message_type(transforms=[self._orbital, self._body] if own_attitude else [self._orbital])

    def publish(self, odometry, t_s: float, q_orbital_to_body) -> None:
        """``eci → orbital`` from the odometry message just written, and ``orbital → base_link`` at ``t_s``."""
        shim.write_orbital_transform(self._orbital, odometry)
        if self._own_attitude:
            shim.write_transform(self._body, t_s, self._frames.orbital, self._frames.base_link, _ORIGIN,
                                 q_orbital_to_body)
        self._dynamic.publish(self._out)
