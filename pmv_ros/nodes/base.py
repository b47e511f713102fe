"""What the pmv_ros nodes share: QoS, the parameter type gate, one source per input, and a lean mode."""

from __future__ import annotations

import time

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import EventHandler, PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from threadpoolctl import ThreadpoolController

import pmv_msgs_shim as shim
from ..runtime.common.clock_watch import CLOCK_STALL_S, CLOCK_WATCH_PERIOD_S, ClockWatch
from ..runtime.common.parameters import unknown_parameter_problem
from ..runtime.common.validation import ClockCheck, JumpDetector, RefusalTally, SourceLock
from .params import coerce_parameters

#: How often (wall clock, s) the graph is asked how many publishers an input has.
GRAPH_CHECK_PERIOD_S = 1.0

#: The clock the source locks measure silence on: the node clock, with a single forged /clock
#: (back by more than 1 s, or ahead by more than 10 s) not believed until the next reading confirms it.
ARRIVAL_JUMP_BACK_S, ARRIVAL_JUMP_AHEAD_S = 1.0, 10.0


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

    def status_name(self, part: str = "") -> str:
        """Name of a /diagnostics status of this node: ``pmv_ros`` + its fully qualified name (+ ``: part``).

        ``pmv_ros/sensor_node: horizon`` with no namespace, ``pmv_ros/sat1/sensor_node: horizon`` in
        ``sat1``: /diagnostics is shared by every spacecraft of a graph, so each status says whose it is.
        """
        return f"pmv_ros{self.get_fully_qualified_name()}" + (f": {part}" if part else "")

    def hardware_id(self, device: str) -> str:
        """``hardware_id`` of this node's /diagnostics statuses: the device and the node's fully qualified name."""
        return f"{device}:{self.get_fully_qualified_name()}"

    def health_report(self, stamp_s: float, health, part: str = "", device: str = "pmv",
                      others: tuple = ()) -> shim.HealthReport:
        """A /diagnostics report of a runtime's status (:class:`pmv_ros.runtime.common.records.HealthSummary`) named
        after this node (:meth:`status_name` of ``part``, :meth:`hardware_id` of ``device``), ``others`` after it."""
        return shim.HealthReport(stamp_s=stamp_s, statuses=(shim.HealthStatus(
            name=self.status_name(part), level=health.level, message=health.message,
            hardware_id=self.hardware_id(device), values=health.values), *others))

    def clock_name(self) -> str:
        """The clock this node runs on, for its start-up line: simulation time from /clock or the wall clock."""
        if self.get_parameter("use_sim_time").value:
            return "on simulation time from /clock"
        return "on the wall clock"

    def __init__(self, name: str, *, lean: bool = False, time_source=None, reliable_inputs: bool | None = None,
                 **kwargs):
        if lean:
            kwargs.setdefault("start_parameter_services", False)
            kwargs.setdefault("enable_rosout", False)  # logs still reach the console and the log file
        self.parameter_specs = {}  # name → ParamSpec, filled by install_validation
        if not hasattr(self, "parameter_refusals"):  # a managed node keeps its count over configure and cleanup
            self.parameter_refusals = RefusalTally("a parameter update")  # counted on /diagnostics, said sparingly
        if not getattr(self, "configuring", False):  # a managed node (nodes/managed.py) is a node already
            super().__init__(name, **kwargs)
        self._lean = lean
        self.source_locks = {}  # input topic (resolved name) → SourceLock (see input_subscription)
        self._input_names = {}  # input topic (resolved name) → the name the node gave (for counter keys)
        self._arrival_clock = JumpDetector(ARRIVAL_JUMP_BACK_S, forward_threshold_s=ARRIVAL_JUMP_AHEAD_S)
        self._source_problems, self._source_checked_s = [], -float("inf")
        self._input_qos = QOS if (lean if reliable_inputs is None else reliable_inputs) else INPUT_QOS
        self._detached = []
        self.clock_check = ClockCheck(ARRIVAL_JUMP_BACK_S, ARRIVAL_JUMP_AHEAD_S)
        self._guarded_clock_subscription = None
        if time_source is None:
            self._guard_clock()
            # use_sim_time switched on later: rclpy subscribes to /clock then; guard that subscription too.
            self.add_post_set_parameters_callback(lambda parameters: self._guard_clock())
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

    # -- /clock -------------------------------------------------------------------------------

    def _guard_clock(self) -> None:
        """Put :class:`~pmv_ros.runtime.common.validation.ClockCheck` in front of rclpy's /clock callback.

        rclpy's time source (created by ``use_sim_time``) hands every /clock
        message straight to its clocks; a negative time raised there and
        stopped the node, and any publisher could set the time. The
        subscription rclpy made is kept (so rclpy can remove it when
        ``use_sim_time`` goes off); only its callback is wrapped: a message
        the check refuses is counted (``rejected_clock_<reason>`` on
        /diagnostics) and never reaches the time source.
        """
        time_source = getattr(self, "_time_source", None)  # rclpy's, created by Node.__init__
        subscription = getattr(time_source, "_clock_sub", None)
        if subscription is None or subscription is self._guarded_clock_subscription:
            return
        forward, check = time_source.clock_callback, self.clock_check

        def on_clock(message, info) -> None:
            clock = message.clock
            if check.admit(clock.sec, clock.nanosec, wall_s=time.monotonic(), gid=_publisher_gid(info),
                           sequence=info.get("publication_sequence_number")) is None:
                forward(message)

        subscription.callback = on_clock
        self._guarded_clock_subscription = subscription

    def watch_clock(self, diagnostics_publisher) -> None:
        """Say on /diagnostics (through ``diagnostics_publisher``, status ``<node>: clock``) when this node's /clock
        stops, and when it
        moves again (:class:`pmv_ros.runtime.common.clock_watch.ClockWatch`): on a steady wall-clock timer, which runs
        while the node clock stands. Only under ``use_sim_time``, and not for the in-process pipeline's lean
        nodes, whose clocks the pipeline sets itself."""
        if self._lean:
            return
        watch, message = ClockWatch(CLOCK_STALL_S), DiagnosticArray()

        def on_watch() -> None:
            if not self.get_parameter("use_sim_time").value:
                return
            clock_s = self.get_clock().now().nanoseconds * 1e-9
            report = watch.observe(clock_s, time.monotonic())
            if report is not None:
                diagnostics_publisher.publish(shim.write_health(message, shim.HealthReport(
                    stamp_s=max(clock_s, 0.0), statuses=(shim.HealthStatus(
                        name=self.status_name("clock"), level=report.level, message=report.message,
                        hardware_id=self.hardware_id("clock"),
                        values={"clock_stalls": watch.stalls}),))))

        self.clock_watch = watch
        self.create_timer(CLOCK_WATCH_PERIOD_S, on_watch, clock=Clock(clock_type=ClockType.STEADY_TIME))

    # -- parameters ---------------------------------------------------------------------------

    def _gate(self, parameters):
        checked, problem = coerce_parameters(self.parameter_specs, parameters)
        if problem:
            self.note_parameter_refusal(problem)
        else:  # a name the node does not have: rclpy refuses it; counted here as every other refusal
            unknown = [p.name for p in parameters if not self.has_parameter(p.name)]
            if unknown:
                self.note_parameter_refusal(unknown_parameter_problem(unknown[0], self.get_name(), ())
                                            or f"{unknown[0]!r} is not declared")
        return checked, problem

    def note_parameter_refusal(self, reason: str) -> None:
        """Count one refused parameter update (``rejected_parameter_updates`` on /diagnostics); log it only if
        :class:`~pmv_ros.runtime.common.validation.RefusalTally` says so (a storm is not a line per request)."""
        if not hasattr(self, "parameter_refusals"):  # a managed node before its first configure
            self.parameter_refusals = RefusalTally("a parameter update")
        line = self.parameter_refusals.refuse(reason, time.monotonic())
        if line is not None:
            self.get_logger().warning(line)

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

    def listened(self, publisher) -> bool:
        """Whether a message on ``publisher`` can reach anyone: False only for a lean node's publisher that has
        no subscription (the in-process pipeline's graph is private, so nothing else can join it unseen; a
        recorder or a probe in the process subscribes, and then the topic is published). The main job skips
        building and publishing what nobody reads (its /clock, raw angles, crossings and Imu output)."""
        return not self._lean or publisher.get_subscription_count() > 0

    def subscription(self, message_type, topic: str, callback, qos: QoSProfile = QOS):
        """A subscription with the project QoS."""
        if self._lean:
            return self.create_subscription(message_type, topic, callback, qos,
                                            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
        return self.create_subscription(message_type, topic, callback, qos)

    def input_subscription(self, message_type, topic: str, callback, source_timeout_s: float = 1.0):
        """A subscription to an input, from one source only: ``callback(message)`` for the locked publisher's messages.

        ``topic`` is resolved in the node's namespace (a relative name moves with it); the lock is kept under
        the resolved name in :attr:`source_locks`, so each spacecraft's stream has its own.

        Best effort unless the node takes its inputs reliably (see ``__init__``).
        The message info's publisher GID, or on Jazzy its publication
        sequence number, goes to a :class:`pmv_ros.runtime.common.validation.SourceLock`
        (the rule is there): the first publisher heard is kept, a second one's
        messages are dropped and counted, never interleaved;
        :meth:`input_source_problems` says so for ``/diagnostics``. Silence
        is measured on the node clock (simulation time under ``use_sim_time``:
        a source restarted in a fast-time run is taken over after
        ``source_timeout_s`` of simulation time), through a jump detector: a
        single forged ``/clock`` cannot make the locked source look silent.
        """
        lock = SourceLock(source_timeout_s)

        def on_message(message, info) -> None:
            stamp = message.header.stamp
            if lock.admit(self._arrival_s(), gid=_publisher_gid(info), sequence=info.get("publication_sequence_number"),
                          stamp_s=stamp.sec + stamp.nanosec * 1e-9):
                callback(message)

        subscription = self.subscription(message_type, topic, on_message, self._input_qos)
        # Keyed by the name resolved in the node's namespace: one lock per stream of one spacecraft.
        self.source_locks[subscription.topic_name] = lock
        self._input_names[subscription.topic_name] = topic
        return subscription

    def _arrival_s(self) -> float:
        """Now on the node clock, s, as the source locks see it (a jump counts once the next reading confirms it)."""
        self._arrival_clock.observe(self.get_clock().now().nanoseconds * 1e-9)
        return self._arrival_clock.latest_s

    def input_source_problems(self, max_age_s: float = GRAPH_CHECK_PERIOD_S) -> list[str]:
        """One phrase per input that has more than one publisher (an ERROR on /diagnostics); [] when none has.

        The graph is asked at most every ``max_age_s`` of wall time (a caller with its own cadence passes 0).
        """
        wall = time.monotonic()
        if wall - self._source_checked_s < max_age_s:
            return list(self._source_problems)
        self._source_checked_s, problems = wall, []
        now = self._arrival_s()
        clocks = self.clock_check.sources.sources_heard(wall)
        if self._guarded_clock_subscription is not None:  # on use_sim_time: /clock is an input like the others
            clocks = max(clocks, self.count_publishers("/clock"))
        if clocks > 1:
            problems.append(f"{clocks} publishers of /clock: only the first one heard sets the time "
                            f"({self.clock_check.counts['other_source']} messages of others dropped)")
        for topic, lock in self.source_locks.items():
            count = self.count_publishers(topic)
            if count > 1 or lock.sources_heard(now) > 1:
                problems.append(f"{max(count, lock.sources_heard(now))} publishers of {topic}: only the first one "
                                f"heard is used ({lock.other_source_messages} messages of others dropped)")
        self._source_problems = problems
        return list(problems)

    def set_source_timeout(self, timeout_s: float) -> None:
        """A new ``input.source_timeout_s`` for every input's source lock (a parameter change)."""
        for lock in self.source_locks.values():
            lock.timeout_s = timeout_s

    def input_source_counters(self) -> dict:
        """``other_source_<topic>``: messages dropped per input because a second publisher sent them;
        ``rejected_clock_<reason>``: /clock messages that did not set the time (see :meth:`_guard_clock`)."""
        # Keys from the names the node gave (other_source_attitude_truth), the same in every namespace.
        counters = {}
        for topic, lock in self.source_locks.items():
            stream = self._input_names[topic].strip("/").replace("/", "_")
            if lock.other_source_messages:
                counters[f"other_source_{stream}"] = lock.other_source_messages
            if lock.lock_changes:  # the source given up after its silence, another taken
                counters[f"source_changes_{stream}"] = lock.lock_changes
        counters.update({f"rejected_clock_{reason}": count for reason, count in self.clock_check.counts.items()
                         if count})
        refusals = getattr(self, "parameter_refusals", None)
        if refusals is not None and refusals.count:
            counters["rejected_parameter_updates"] = refusals.count
        return counters


def _publisher_gid(info):
    """The publisher's GID as bytes from rclpy's message info (rclpy ≥ Kilted), None where it has none (Jazzy)."""
    gid = info.get("publisher_gid") if isinstance(info, dict) else None
    if gid is None:
        return None
    try:
        return bytes(gid.get("data", gid) if isinstance(gid, dict) else gid)
    except (TypeError, ValueError):
        return None
