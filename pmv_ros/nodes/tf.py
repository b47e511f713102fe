"""The sensor's transforms on ``/tf`` and ``/tf_static``, when ``tf2_msgs`` is there.

``tf2_msgs`` is not on the package registries (users have it from their ROS 2
install), so it is imported here only, and its absence is a state, not an
error: :func:`tf_message_type` is None, the sensor says so once at start-up
and publishes no transforms; everything else runs as before.

Published (interfaces.md "Topics", /tf and /tf_static; declared by :func:`transform_topics`):

* ``/tf_static``, once, reliable and transient local (a late listener gets
  it): ``base_link → pmv_sensor``, the mounting;
* ``/tf`` with every sample: ``eci → orbital`` (the orbit: the same pose as
  /orbit/odometry) and, with the sensor's own attitude model only,
  ``orbital → base_link`` (the attitude of /attitude/truth). In follow mode
  the user's stack owns the attitude and that transform.
"""

from __future__ import annotations

from geometry_msgs.msg import TransformStamped
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

import pmv_msgs_shim as shim
from ..runtime.sensor.runtime import SamplePublication
from .base import Pub

#: /tf: as tf2_ros's TransformBroadcaster (reliable, volatile, keep-last 100).
TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
#: /tf_static: as tf2_ros's StaticTransformBroadcaster (reliable, transient local, keep-last 1).
TF_STATIC_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)

#: What the sensor logs once at start-up when it cannot publish transforms.
NO_TF2_MSGS = ("tf2_msgs cannot be imported (it comes with a ROS 2 install, not from the package registries): "
               "no /tf or /tf_static from this node; every other topic is published as usual")

_ORIGIN = (0.0, 0.0, 0.0)
_ODOMETRY = Odometry()  # scratch: the orbital transform is the pose an odometry message of the sample holds


def tf_message_type():
    """``tf2_msgs.msg.TFMessage``, or None when tf2_msgs cannot be imported."""
    try:
        from tf2_msgs.msg import TFMessage
    except ImportError:
        return None
    return TFMessage


def _write_mounting(message, stamp_s: float, node):
    frames = node.frames
    shim.write_transform(message.transforms[0], max(stamp_s, 0.0), frames.base_link, frames.sensor, _ORIGIN,
                         node.q_body_to_sensor)
    return message


def _write_sample(message, item: SamplePublication, node):
    """``eci → orbital`` at the sample and, with the own attitude model, ``orbital → base_link``."""
    frames, sample = node.frames, item.sample
    shim.write_orbit_state(_ODOMETRY, sample.t_s, frames.eci, frames.orbital, sample.position_eci_m,
                           sample.velocity_eci_m_s)
    shim.write_orbital_transform(message.transforms[0], _ODOMETRY)
    if len(message.transforms) > 1:
        shim.write_transform(message.transforms[1], sample.t_s, frames.orbital, frames.base_link, _ORIGIN,
                             sample.q_xyzw)
    return message


def transform_topics(message_type) -> tuple:
    """The sensor's /tf_static (fed once, under ``"mounting"``, with the node clock at start-up) and /tf (fed by
    every sample) with ``message_type`` (``TFMessage``)."""
    return (Pub("/tf_static", message_type, "mounting", _write_mounting, qos=TF_STATIC_QOS,
                make=lambda node: message_type(transforms=[TransformStamped()])),
            Pub("/tf", message_type, SamplePublication, _write_sample, qos=TF_QOS, make=lambda node: message_type(
                transforms=[TransformStamped() for _ in range(1 if node.follows_attitude else 2)])))
