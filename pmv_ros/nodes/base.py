"""What the pmv_ros nodes share: QoS, the parameter type gate, and a lean mode for the in-process pipeline."""

from __future__ import annotations

from rcl_interfaces.msg import SetParametersResult
from rclpy.event_handler import EventHandler, PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from threadpoolctl import ThreadpoolController

from .params import coerce_parameters


_blas_holders = 0
_blas_limiter = None


def hold_single_threaded_blas() -> None:
    """Run BLAS (numpy's matrix products) on one thread in this process until the last holder releases it.

    The nodes' numerics are small products (the radiance environment's
    spectral synthesis is the largest). Left to itself OpenBLAS splits them
    over every core, where on a 2-core machine its threads contend with the
    executor, the DDS threads and any other busy process: a block of sensor
    samples then took 4–10× longer than on one thread. Holders are counted,
    so pipelines that overlap in one process restore the original setting
    only when the last of them is released.
    """
    global _blas_holders, _blas_limiter
    if _blas_holders == 0:
        _blas_limiter = ThreadpoolController().limit(limits=1, user_api="blas")
    _blas_holders += 1


def release_single_threaded_blas() -> None:
    """Undo one :func:`hold_single_threaded_blas`; the last release restores the original BLAS threads."""
    global _blas_holders, _blas_limiter
    if _blas_holders == 0:
        return
    _blas_holders -= 1
    if _blas_holders == 0:
        _blas_limiter.restore_original_limits()
        _blas_limiter = None


#: Every pmv_ros publisher: reliable, keep-last 100, volatile. At the highest
#: sensor rate (100 Hz) that is one second of messages per topic; a
#: subscriber that falls further behind loses the oldest, it never makes the
#: publisher wait or a queue grow. The in-process pipeline drains the graph
#: after every tick, so its queues hold a handful of messages.
QOS_DEPTH = 100
QOS = QoSProfile(depth=QOS_DEPTH)

#: Subscriptions to inputs (/attitude/truth, /star_tracker/attitude,
#: /pmv/attitude, /orbit/odometry): best effort, keep-last 100, volatile. A
#: best-effort subscription is matched by reliable and best-effort publishers
#: alike (REP-2003: an estimator publishing with ``qos_profile_sensor_data``
#: must be able to feed us); a reliable one would never hear a best-effort one.
INPUT_QOS = QoSProfile(depth=QOS_DEPTH, reliability=ReliabilityPolicy.BEST_EFFORT)


class PmvNode(Node):
    """A node with the project's QoS, a parameter type gate and an optional lean mode.

    Args:
        name: node name.
        lean: for the in-process pipeline (``pmv simulate``), whose graph
            nothing outside the process can see: no parameter services, no
            /rosout publisher and no default QoS-event handlers. Each of those is an entity the
            executor re-examines on every wait; dropping them almost doubles
            the fast-time rate. Parameters still work through
            ``set_parameters`` in-process, with the same validation.
        time_source: for the in-process pipeline: a ``rclpy.time_source.TimeSource``
            that the process drives itself (``clock_callback``). The node runs
            with ``use_sim_time`` as usual, but its clock follows this source and
            the /clock subscription ``use_sim_time`` made is dropped: nodes that
            share the process learn the time from the pipeline, not through DDS.
        reliable_inputs: subscribe to inputs reliably (:data:`QOS`) instead of
            best effort (:data:`INPUT_QOS`). Default: in lean mode, where every
            publisher is one of ours and reliable, so the pipeline is lossless.

    Parameter updates (in-process ``set_parameters`` and the parameter
    services alike) pass :func:`pmv_ros.nodes.params.coerce_parameters` first:
    a value of the wrong type or out of range is refused with a reason that
    names the value and what is allowed, and an integer for a floating-point
    parameter is taken as a float. The specs come from
    :func:`pmv_ros.nodes.params.install_validation`.
    """

    def __init__(self, name: str, *, lean: bool = False, time_source=None, reliable_inputs: bool | None = None,
                 **kwargs):
        if lean:
            kwargs.setdefault("start_parameter_services", False)
            kwargs.setdefault("enable_rosout", False)  # logs still reach the console and the log file
        self.parameter_specs = {}  # name → ParamSpec, filled by install_validation
        super().__init__(name, **kwargs)
        self._lean = lean
        self._input_qos = QOS if (lean if reliable_inputs is None else reliable_inputs) else INPUT_QOS
        self._detached = []
        if time_source is not None:
            for subscription in [s for s in self.subscriptions if s.topic_name == "/clock"]:
                self.destroy_subscription(subscription)
            # Before a subclass reads its clock: the node starts on the pipeline's simulation time.
            time_source.attach_clock(self.get_clock())
        if lean:
            # rclpy's own /parameter_events publisher (and /clock subscription)
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

    # -- parameters ---------------------------------------------------------------------------

    def _gate(self, parameters):
        checked, problem = coerce_parameters(self.parameter_specs, parameters)
        if problem:
            self.get_logger().warning(f"rejected parameter update: {problem}")
        return checked, problem

    def set_parameters(self, parameter_list):
        """Set parameters one by one (rclpy semantics), each through the type gate first."""
        results = []
        for parameter in parameter_list:
            checked, problem = self._gate([parameter])
            results.append(SetParametersResult(successful=False, reason=problem) if problem
                           else super().set_parameters(checked)[0])
        return results

    def set_parameters_atomically(self, parameter_list):
        """Set parameters all or none (what the parameter services call), through the type gate first."""
        checked, problem = self._gate(parameter_list)
        if problem:
            return SetParametersResult(successful=False, reason=problem)
        return super().set_parameters_atomically(checked)

    # -- topics -------------------------------------------------------------------------------

    def publisher(self, message_type, topic: str):
        """A publisher with the project QoS."""
        if self._lean:
            return self.create_publisher(message_type, topic, QOS,
                                         event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))
        return self.create_publisher(message_type, topic, QOS)

    def subscription(self, message_type, topic: str, callback, qos: QoSProfile = QOS):
        """A subscription with the project QoS."""
        if self._lean:
            return self.create_subscription(message_type, topic, callback, qos,
                                            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        return self.create_subscription(message_type, topic, callback, qos)

    def input_subscription(self, message_type, topic: str, callback):
        """A subscription to an input: best effort unless the node takes its inputs reliably (see ``__init__``)."""
        return self.subscription(message_type, topic, callback, self._input_qos)
