"""``attitude_controller_node``: a rigid spacecraft held nadir-pointing by a PD loop closed on the PMV.

Subscribes to ``pmv/attitude`` (the sensor's roll and pitch), integrates the plant and publishes its true
attitude on ``attitude/truth`` — which a sensor in follow mode measures and the star tracker observes — and
the transform ``orbital → base_link`` on ``/tf``; health on ``/diagnostics``. So the loop closes through the
sensor's errors, and the true pointing error is what an attitude-control system flying this sensor would get
(physics.md §2.1; ``pmv simulate --closed-loop`` reports it).

The node only wires (:data:`TOPICS`); the plant, the law, the input checks and the pointing error are its
runtime's (:class:`pmv_ros.runtime.control.ControllerRuntime`), the physics
:mod:`pmv_ros.physics.rigid_body`. Write your own controller by copying this file and that runtime's
``_step``: the wiring stays as it is.

A timer at ``control.rate_hz`` on the node clock advances the plant to the clock (on ``/clock`` with
``use_sim_time``); in the in-process pipeline the pipeline steps it instead, before each sensor sample
(:meth:`AttitudeControllerNode.step_to`).
"""

from __future__ import annotations

import sys

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, TransformStamped, Vector3Stamped

import pmv_msgs_shim as shim
from .base import PmvNode, Pub, Sub
from ..runtime.common.assembly import CONTROLLER_PARAMS as PARAMS
from ..runtime.common.records import HealthAt
from ..runtime.control import ControllerRuntime, PointingStatistics, TruthPublication
from .launch import node_main
from .managed import ManagedNode
from .params import ParameterError, declare, install_validation
from .tf import NO_TF2_MSGS, TF_QOS, tf_message_type

_ORIGIN = (0.0, 0.0, 0.0)


def _write_transform(message, state: TruthPublication, node):
    """``orbital → base_link``: the plant's attitude."""
    frames = node.frames
    shim.write_transform(message.transforms[0], state.t_s, frames.orbital, frames.base_link, _ORIGIN, state.q_xyzw)
    return message


#: What the controller publishes and takes (relative names: in a namespace, this spacecraft's topics move under
#: it, interfaces.md "Topics"); /tf when tf2_msgs is there (:func:`_transform_topic`).
TOPICS = (
    Pub("attitude/truth", QuaternionStamped, TruthPublication, lambda m, s, n: shim.write_attitude_quaternion(
        m, s.t_s, n.frames.orbital, s.q_xyzw)),
    Pub("/diagnostics", DiagnosticArray, HealthAt, lambda m, h, n: shim.write_health(
        m, n.health_report(h.stamp_s, h.health, device="attitude_control"))),
    Sub("pmv/attitude", Vector3Stamped, shim.angles_input, "add_measurement"),
)


def _transform_topic(message_type) -> Pub:
    return Pub("/tf", message_type, TruthPublication, _write_transform, qos=TF_QOS,
               make=lambda node: message_type(transforms=[TransformStamped()]))


class AttitudeControllerNode(PmvNode):
    """The plant and its PD loop on ``pmv/attitude``.

    Args (of :meth:`build`, given to the constructor):
        external_drive: the caller advances the plant (:meth:`step_to`), no timer (the in-process pipeline).
        publish_tf: publish ``orbital → base_link`` on /tf (when tf2_msgs is there).
    """

    NODE_NAME = "attitude_controller_node"

    def build(self, *, external_drive: bool = False, publish_tf: bool = True) -> None:
        """Parameters, runtime, topics and the control timer (see :class:`~pmv_ros.nodes.base.PmvNode`)."""
        self._values = declare(self, PARAMS)
        try:
            self._runtime = ControllerRuntime(self._values, start_s=self.now_s(),
                                              source_counters=self.input_source_counters)
        except ValueError as error:  # a combination the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, self._values, self._runtime.reconfigure)
        tf_message = tf_message_type() if publish_tf else None
        if publish_tf and tf_message is None:
            self.get_logger().warning(NO_TF2_MSGS)
        self.wire(TOPICS + ((_transform_topic(tf_message),) if tf_message else ()),
                  self._values["input.source_timeout_s"])
        if not external_drive:
            self.make_timer(1.0 / self._values["control.rate_hz"], self._on_timer)
        v = self._values
        self.get_logger().info(f"{self.get_fully_qualified_name()}: PD loop on pmv/attitude, bandwidth "
                               f"{v['control.bandwidth_hz']:g} Hz, damping {v['control.damping_ratio']:g}, yaw "
                               f"{v['control.yaw']}, inertia {list(v['body.inertia_kg_m2'])} kg m2, "
                               f"{v['control.rate_hz']:g} Hz, {self.clock_name()}")

    def _on_timer(self) -> None:
        self.take_output(self._runtime.tick(self.now_s()))

    def step_to(self, t_s: float) -> None:
        """Advance the plant by whole control steps until its time reaches ``t_s``, publishing each step (a host
        that drives the loop calls this before it needs the attitude at ``t_s``)."""
        self.take_output(self._runtime.step_to(t_s))

    def step_at_next_measurement(self, t_s: float) -> None:
        """The same, as soon as the next ``pmv/attitude`` message is taken (in its callback): a host that has just
        had the sensor measure needs no second pass of the executor for the plant to move on
        (:meth:`~pmv_ros.runtime.control.ControllerRuntime.step_at_next_measurement`)."""
        self._runtime.step_at_next_measurement(t_s)

    @property
    def pointing(self) -> PointingStatistics:
        """The true pointing error so far (after the loop's settling time)."""
        return self._runtime.pointing


class ManagedAttitudeControllerNode(ManagedNode, AttitudeControllerNode):
    """:class:`AttitudeControllerNode` as a managed (lifecycle) node (:mod:`pmv_ros.nodes.managed`)."""


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros attitude_controller_node [--managed]``."""
    return node_main(AttitudeControllerNode, ManagedAttitudeControllerNode, args)


if __name__ == "__main__":
    sys.exit(main())
