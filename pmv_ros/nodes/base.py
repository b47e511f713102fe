"""What the pmv_ros nodes share: QoS, the parameter type gate, one source per input, a lean mode, and the wiring.

A node declares its topics in a table (:class:`Pub`, :class:`Sub`: name, type, QoS, which runtime output feeds
it or which runtime input a message goes to); :meth:`PmvNode.wire` builds them and the node only hands what a
runtime input returned to :meth:`PmvNode.take_output`.
"""

from __future__ import annotations

import inspect
import time
from typing import Callable, NamedTuple

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import EventHandler, PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSPolicyKind, QoSProfile, ReliabilityPolicy

import pmv_msgs_shim as shim
from ..runtime.common.clock_watch import CLOCK_STALL_S, CLOCK_WATCH_PERIOD_S, ClockWatch
from ..runtime.common.input_sources import GRAPH_CHECK_PERIOD_S, InputSources
from ..runtime.common.parameters import unknown_parameter_problem
from ..runtime.common.refusals import RefusalTally
from .params import coerce_parameters
from .rclpy_internals import RCLPY_VERSION, WRITTEN_FOR, clock_now_s, guard_clock, internals_in_use

#: A batching node hands its queued inputs to the runtime at the latest when this many wait (memory bound).
MAX_QUEUED_INPUTS = 1000

#: Every pmv_ros publisher: reliable, keep-last 100, volatile. At the highest sensor rate (100 Hz) that is one
#: second of messages per topic; a subscriber that falls further behind loses the oldest, it never makes the
#: publisher wait or a queue grow. The in-process pipeline drains the graph after every tick.
QOS_DEPTH = 100
QOS = QoSProfile(depth=QOS_DEPTH)

#: Subscriptions to inputs: best effort, keep-last 100, volatile. A best-effort subscription is matched by
#: reliable and best-effort publishers alike (REP-2003: an estimator publishing with ``qos_profile_sensor_data``
#: must be able to feed us); a reliable one would never hear a best-effort one.
INPUT_QOS = QoSProfile(depth=QOS_DEPTH, reliability=ReliabilityPolicy.BEST_EFFORT)


_QUIET = {"Publisher": {"event_callbacks": PublisherEventCallbacks(use_default_callbacks=False)},
          "Subscription": {"event_callbacks": SubscriptionEventCallbacks(use_default_callbacks=False)}}


class Pub(NamedTuple):
    """A topic a node publishes: ``write(message, item, node)`` fills the node's one message of it (made by
    ``make(node)``, else ``type()``) from each item of the runtime output ``feed`` (an item type, or a name the
    node emits under). Made only where ``when(node)`` holds."""

    topic: str
    type: type
    feed: object
    write: Callable
    qos: QoSProfile = QOS
    when: Callable | None = None
    make: Callable | None = None


def _keywords(function) -> tuple:
    """The names ``function`` takes as keywords (not ``self``, not ``**``)."""
    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return tuple(name for name, parameter in inspect.signature(function).parameters.items()
                 if parameter.kind in kinds and name != "self")


class Sub(NamedTuple):
    """An input a node subscribes to, from one source only: ``read(message)`` gives the arguments of the
    runtime input ``to`` (before the node clock, which comes last). Made only where ``when(node)`` holds."""

    topic: str
    type: type
    read: Callable
    to: str
    when: Callable | None = None


class PmvNode(Node):
    """A node with the project's QoS, a parameter type gate, declared topics and an optional lean mode.

    Args:
        node_name: the node's name (default: the class's :attr:`NODE_NAME`).
        lean: for the in-process pipeline (``pmv simulate``), whose graph nothing outside the process can see:
            no parameter or type-description services, no /rosout publisher, no default QoS-event handlers (each
            an entity the executor re-examines on every wait), and nothing built or published on a topic nobody
            in the process subscribes to. Parameters still work through ``set_parameters``, with the same validation.
        time_source: for the in-process pipeline: a ``rclpy.time_source.TimeSource`` the process drives itself;
            the node runs with ``use_sim_time``, its clock follows this source, and the /clock subscription
            ``use_sim_time`` made is dropped.
        reliable_inputs: subscribe to inputs reliably (:data:`QOS`) instead of best effort (:data:`INPUT_QOS`).
            Default: in lean mode, where every publisher is one of ours and reliable, so the pipeline is lossless.
        The keyword arguments :meth:`build` takes go to it; the others make the rclpy node (``context``,
        ``parameter_overrides``, …).

    A node class with ``BATCHED = True`` queues its inputs and hands them to its runtime's ``add_inputs`` once per
    executor wake-up (:meth:`flush_inputs`, on a guard condition) — or, with ``flushed_by_caller``, when the caller
    says (the in-process pipeline: each time its drain finds the graph idle). Parameter updates pass
    :func:`pmv_ros.nodes.params.coerce_parameters` first: a wrong type or a value out of range is refused with a
    reason that names it; an integer for a floating-point parameter is taken as a float.

    **Node and configuration** (what :class:`pmv_ros.nodes.managed.ManagedNode` builds on):

    * ``__init__`` makes the rclpy node and what it keeps for its whole life (the parameter type gate, the /clock
      check, a lean node's options), then calls :meth:`begin` with the arguments of :meth:`build`;
    * :meth:`begin`: a plain node makes its configuration at once (:meth:`configure_node`); a managed node keeps
      the arguments and makes one at each configure;
    * :meth:`configure_node`: a fresh configuration (input sources, declared topics, queue), then :meth:`build`,
      which a node class overrides: it declares its parameters, makes its runtime, wires its topics and timers;
    * a configuration makes its entities only through :meth:`make_publisher`, :meth:`make_subscription`,
      :meth:`make_timer`, :meth:`make_guard_condition` and :meth:`add_parameter_check`: a managed node overrides
      them to hold what is made still until activation and to release it at cleanup.
    """

    BATCHED = False
    #: The node's name when none is given.
    NODE_NAME: str | None = None

    def status_name(self, part: str = "") -> str:
        """``pmv_ros`` + this node's fully qualified name (+ ``: part``): a /diagnostics status says whose it is."""
        return f"pmv_ros{self.get_fully_qualified_name()}" + (f": {part}" if part else "")

    def hardware_id(self, device: str) -> str:
        """``hardware_id`` of this node's /diagnostics statuses: the device and the node's fully qualified name."""
        return f"{device}:{self.get_fully_qualified_name()}"

    def health_report(self, stamp_s: float, health, part: str = "", device: str = "pmv",
                      others: tuple = ()) -> shim.HealthReport:
        """A /diagnostics report of a runtime's :class:`~pmv_ros.runtime.common.records.HealthSummary` named
        after this node (:meth:`status_name` of ``part``, :meth:`hardware_id` of ``device``), ``others`` after it."""
        return shim.HealthReport(stamp_s=stamp_s, statuses=(shim.HealthStatus(
            name=self.status_name(part), level=health.level, message=health.message,
            hardware_id=self.hardware_id(device), values=health.values), *others))

    def now_s(self) -> float:
        """The node clock, s: one reading (:func:`clock_s`)."""
        return clock_s(self.get_clock())

    def clock_name(self) -> str:
        """The clock this node runs on, for its start-up line: simulation time from /clock or the wall clock."""
        return "on simulation time from /clock" if self.get_parameter("use_sim_time").value else "on the wall clock"

    @property
    def runtime(self):
        """The node's runtime (what its inputs and ticks go to), None for a node without one or not configured."""
        return getattr(self, "_runtime", None)

    @property
    def frames(self):
        """The frame names of this node's runtime (:class:`~pmv_ros.runtime.common.frames.Frames`, with the
        namespace's prefix)."""
        return self._runtime.frames

    def __init__(self, node_name: str | None = None, *, lean: bool = False, time_source=None,
                 reliable_inputs: bool | None = None, flushed_by_caller: bool = False, **kwargs):
        build_arguments = {name: kwargs.pop(name) for name in _keywords(type(self).build) if name in kwargs}
        if lean:
            kwargs.setdefault("start_parameter_services", False)
            kwargs.setdefault("enable_rosout", False)  # logs still reach the console and the log file
            kwargs["parameter_overrides"] = [*kwargs.get("parameter_overrides", ()),
                                             Parameter("start_type_description_service", value=False)]
        self.parameter_specs = {}  # name → ParamSpec, filled by install_validation
        super().__init__(node_name or self.NODE_NAME, **kwargs)
        self._lean, self._flushed_by_caller = lean, flushed_by_caller
        self._input_qos = QOS if (lean if reliable_inputs is None else reliable_inputs) else INPUT_QOS
        self._detached, self._guarded_clock_subscription = [], None
        self._clock_subscribed = False  # /clock is an input: use_sim_time on, the time source rclpy's own
        self._unchecked_clock_said = False
        self._new_configuration()
        if time_source is None:
            self._guard_clock()
            # use_sim_time switched on later: rclpy subscribes to /clock then; guard that subscription too.
            self.add_post_set_parameters_callback(lambda parameters: self._guard_clock())
        else:
            for subscription in [s for s in self.subscriptions if s.topic_name == "/clock"]:
                self.destroy_subscription(subscription)
            time_source.attach_clock(self.get_clock())  # before a subclass reads its clock
        if lean:  # rclpy's own /parameter_events publisher's QoS-event handlers only cost time in a private graph
            for waitable in [w for w in self.waitables if isinstance(w, EventHandler)]:
                self.remove_waitable(waitable)
                self._detached.append(waitable)
        self.begin(build_arguments)

    # -- node and configuration ---------------------------------------------------------------------

    def begin(self, arguments: dict) -> None:
        """The end of construction, with the keyword arguments of :meth:`build`: a plain node makes its
        configuration now."""
        self.configure_node(arguments)

    def configure_node(self, arguments: dict) -> None:
        """A fresh configuration: new input sources, no declared topics, nothing queued; then :meth:`build`."""
        self._new_configuration()
        self.build(**arguments)

    def build(self) -> None:
        """What the node makes from its parameters (a node class overrides it, with its own keyword arguments):
        parameters declared and checked, runtime, topics, timers — made through the ``make_*`` methods."""

    def _new_configuration(self) -> None:
        self.sources = InputSources()  # the inputs' source locks and the /clock check
        self._feeds, self.topic_publishers, self._queued = {}, {}, []

    def make_publisher(self, message_type, topic: str, qos: QoSProfile, **options):
        """A publisher of the configuration (``create_publisher``'s arguments)."""
        return self.create_publisher(message_type, topic, qos, **options)

    def make_subscription(self, message_type, topic: str, callback, qos: QoSProfile, **options):
        """A subscription of the configuration (``create_subscription``'s arguments)."""
        return self.create_subscription(message_type, topic, callback, qos, **options)

    def make_timer(self, period_s: float, callback, clock: Clock | None = None):
        """A timer of the configuration (``create_timer``'s arguments)."""
        return self.create_timer(period_s, callback, clock=clock)

    def make_guard_condition(self, callback):
        """A guard condition of the configuration (``create_guard_condition``'s argument)."""
        return self.create_guard_condition(callback)

    def add_parameter_check(self, callback) -> None:
        """A set-parameters callback of the configuration (``add_on_set_parameters_callback``)."""
        self.add_on_set_parameters_callback(callback)

    def quiet_options(self, kind: str, topic: str = "") -> dict:
        """The options of a ``"Publisher"`` or ``"Subscription"`` of this node on ``topic``: a lean node's come
        without rclpy's default QoS-event handlers; any other node's incompatible-QoS event goes to
        :meth:`note_incompatible_qos` instead of rclpy's default, which logs a warning per event (a neighbour
        that keeps making mismatched endpoints floods every node's log)."""
        if self._lean:
            return _QUIET[kind]
        callbacks = PublisherEventCallbacks if kind == "Publisher" else SubscriptionEventCallbacks
        return {"event_callbacks": callbacks(
            incompatible_qos=lambda event: self.note_incompatible_qos(kind, topic, event))}

    def note_incompatible_qos(self, kind: str, topic: str, event) -> None:
        """Count endpoints of others whose QoS cannot match one of ours (``incompatible_qos`` on /diagnostics);
        log it only when :class:`~pmv_ros.runtime.common.refusals.RefusalTally` says so."""
        if not hasattr(self, "incompatible_qos"):
            self.incompatible_qos = RefusalTally("a QoS-incompatible endpoint")
        try:
            policy = QoSPolicyKind(event.last_policy_kind).name.lower()
        except ValueError:
            policy = str(event.last_policy_kind)
        peer = "subscription" if kind == "Publisher" else "publisher"
        line = None
        for _ in range(max(int(getattr(event, "total_count_change", 1)), 1)):
            line = self.incompatible_qos.refuse(
                f"a {peer} on {topic or 'a topic of ours'} asks for an incompatible {policy} policy: it hears "
                f"nothing from this node", time.monotonic()) or line
        if line is not None:
            self.get_logger().warning(line)

    def destroy_node(self):
        """Destroy the node (re-attaching detached handlers first: rclpy removes them with their publisher)."""
        for waitable in self._detached:
            self.add_waitable(waitable)
        self._detached = []
        return super().destroy_node()

    # -- the declared topics ----------------------------------------------------------------------

    def wire(self, topics, source_timeout_s: float) -> None:
        """Build the publishers and input subscriptions of ``topics`` (:class:`Pub`, :class:`Sub`) whose ``when``
        holds, in table order; with a /diagnostics publisher, :meth:`watch_clock`; a batching node's wake-up."""
        for topic in topics:
            if topic.when is not None and not topic.when(self):
                continue
            if isinstance(topic, Sub):
                self._input(topic, source_timeout_s)
                continue
            publisher = self.make_publisher(topic.type, topic.topic, topic.qos,
                                            **self.quiet_options("Publisher", topic.topic))
            message = topic.make(self) if topic.make is not None else topic.type()
            # A latched topic always goes out: a later subscriber gets the last message.
            always = not self._lean or topic.qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
            self._feeds.setdefault(topic.feed, []).append((publisher, message, topic.write, always))
            self.topic_publishers[topic.topic] = publisher
        if self.BATCHED and not self._flushed_by_caller:
            self._wake = self.make_guard_condition(self.flush_inputs)
        if "/diagnostics" in self.topic_publishers:
            self.watch_clock()

    def emit(self, feed, item, readers: dict | None = None) -> None:
        """Publish ``item`` on every topic ``feed`` feeds (a lean node skips a topic nobody in the process reads:
        its private graph has no one unseen; a recorder or a probe subscribes, and then the topic is published).
        ``readers``: publisher → whether it has a subscriber, as far as known already (see :meth:`take_output`)."""
        for publisher, message, write, always in self._feeds.get(feed, ()):
            if always or _has_reader(publisher, readers):
                publisher.publish(write(message, item, self))

    def take_output(self, output) -> None:
        """What a runtime input returned: its log lines (if it has any) to the node's log, then each item it
        publishes, in order, :meth:`emit` under its type. The graph is asked once per output whether a topic has a
        subscriber (≈ 1 µs a question): nothing in the process can subscribe between two of its items."""
        if output is None:
            return
        for line in getattr(output, "log", ()):  # two call sites: rclpy's logger refuses two severities from one
            if line.level == "error":
                self.get_logger().error(line.text)
            else:
                self.get_logger().info(line.text)
        readers = {}
        for item in output.published:
            self.emit(type(item), item, readers)

    def publisher(self, message_type, topic: str):
        """A publisher with the project QoS (outside the table: tests, benchmarks)."""
        return self.make_publisher(message_type, topic, QOS, **self.quiet_options("Publisher", topic))

    def subscription(self, message_type, topic: str, callback, qos: QoSProfile = QOS):
        """A subscription with the project QoS (outside the table: the report collector, benchmarks)."""
        return self.make_subscription(message_type, topic, callback, qos,
                                      **self.quiet_options("Subscription", topic))

    # -- inputs: one source each, then the runtime (at once, or once per wake-up) -----------------------

    def _input(self, declared: Sub, source_timeout_s: float) -> None:
        """Subscribe to ``declared``: only the locked publisher's messages pass (:class:`InputSources`: the locks
        and their clock)."""
        clock, read, to, arrival_s = self.get_clock(), declared.read, declared.to, self.sources.arrival_s

        def on_message(message, info) -> None:
            now_s = clock_s(clock)  # one reading: the arrival and the input's clock
            stamp = message.header.stamp
            changes = lock.lock_changes
            if lock.admit(arrival_s(now_s), gid=_publisher_gid(info),
                          sequence=info.get("publication_sequence_number"), stamp_s=stamp.sec + stamp.nanosec * 1e-9):
                if lock.lock_changes != changes:
                    self.on_new_source(topic)
                self._take_input(to, read(message), self.input_clock(now_s))

        subscription = self.make_subscription(declared.type, declared.topic, on_message, self._input_qos,
                                              **self.quiet_options("Subscription", declared.topic))
        topic = subscription.topic_name  # resolved once, by rcl (namespace and remapping): one lock per spacecraft
        lock = self.sources.lock(topic, declared.topic, source_timeout_s)  # before any message: none is taken yet
        lock.crowded = lambda: self.count_publishers(topic) > 1  # a starved source stays locked

    def on_new_source(self, topic: str) -> None:
        """Another publisher took the input ``topic`` (its old source gone); called before its first message is
        handed over. A node whose output depends on one source's timeline overrides this."""

    def input_clock(self, now_s: float) -> float | None:
        """The node clock as an input sees it: None before simulation time started (a node overrides this)."""
        return now_s if now_s > 0.0 else None

    def _take_input(self, to: str, arguments: tuple, now_s) -> None:
        if not self.BATCHED:
            self.take_output(getattr(self._runtime, to)(*arguments, now_s))
            return
        if not self._queued and not self._flushed_by_caller:
            self._wake.trigger()  # ready at the next wait: handled after that wake-up's messages of this node
        self._queued.append((to, arguments, now_s))
        if len(self._queued) >= MAX_QUEUED_INPUTS:
            self.flush_inputs()

    @property
    def queued_inputs(self) -> int:
        """Inputs taken from the subscriptions and not yet handed to the runtime (:meth:`flush_inputs`)."""
        return len(self._queued)

    def flush_inputs(self) -> bool:
        """Hand the queued inputs to the runtime as one batch (``add_inputs``), in arrival order, and publish;
        whether that gave anything to publish."""
        if not self._queued:
            return False
        events, self._queued = self._queued, []
        output = self._runtime.add_inputs(events)
        self.take_output(output)
        return bool(output.published)

    def input_source_problems(self, max_age_s: float = GRAPH_CHECK_PERIOD_S) -> list[str]:
        """:meth:`InputSources.problems`, the graph asked at most every ``max_age_s`` of wall time."""
        return self.sources.problems(self.now_s(), time.monotonic(), self.count_publishers, self._clock_subscribed,
                                     max_age_s)

    def input_source_counters(self) -> dict:
        """:meth:`InputSources.counters`, and ``rejected_parameter_updates``: refused parameter requests."""
        counters = self.sources.counters()
        refusals = getattr(self, "parameter_refusals", None)
        if refusals is not None and refusals.count:
            counters["rejected_parameter_updates"] = refusals.count
        incompatible = getattr(self, "incompatible_qos", None)
        if incompatible is not None and incompatible.count:
            counters["incompatible_qos"] = incompatible.count
        return counters

    # -- /clock -----------------------------------------------------------------------------------

    def _guard_clock(self) -> None:
        """Put :class:`~pmv_ros.runtime.common.validation.ClockCheck` in front of rclpy's /clock callback
        (:func:`~pmv_ros.nodes.rclpy_internals.guard_clock`).

        rclpy's time source hands every /clock message straight to its clocks (a negative time raised there and
        stopped the node; any publisher could set the time). A message the check refuses is counted
        (``rejected_clock_<reason>`` on /diagnostics) and never reaches the time source. Where rclpy offers no
        way to do so (:mod:`~pmv_ros.nodes.rclpy_internals`' fallback), the node says once that /clock goes
        unchecked.
        """
        def admit(message, info) -> bool:
            clock = message.clock
            return self.sources.clock.admit(clock.sec, clock.nanosec, wall_s=time.monotonic(),
                                            gid=_publisher_gid(info),
                                            sequence=info.get("publication_sequence_number")) is None

        self._guarded_clock_subscription = guard_clock(self, admit, self._guarded_clock_subscription)
        self._clock_subscribed = self.get_parameter("use_sim_time").value  # rclpy's /clock subscription is there
        if (self._guarded_clock_subscription is None and not internals_in_use() and not self._unchecked_clock_said
                and self._clock_subscribed):
            self._unchecked_clock_said = True
            self.get_logger().warning(f"/clock is not checked before rclpy's time source takes it (rclpy "
                                      f"{RCLPY_VERSION}: pmv_ros's check is written for rclpy {WRITTEN_FOR})")

    def watch_clock(self) -> None:
        """Say on /diagnostics (status ``<node>: clock``) when this node's /clock stops and when it moves again
        (:class:`~pmv_ros.runtime.common.clock_watch.ClockWatch`), on a steady wall-clock timer that runs while
        the node clock stands. Only under ``use_sim_time``, and not for lean nodes (the pipeline sets their clocks)."""
        if self._lean:
            return
        watch, message, publisher = ClockWatch(CLOCK_STALL_S), DiagnosticArray(), self.topic_publishers["/diagnostics"]

        def on_watch() -> None:
            if self.get_parameter("use_sim_time").value:
                now_s = self.now_s()
                report = watch.observe(now_s, time.monotonic())
                if report is not None:
                    publisher.publish(shim.write_health(message, self.health_report(max(now_s, 0.0), report, "clock",
                                                                                     "clock")))

        self.clock_watch = watch
        self.make_timer(CLOCK_WATCH_PERIOD_S, on_watch, clock=Clock(clock_type=ClockType.STEADY_TIME))

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
        :class:`~pmv_ros.runtime.common.refusals.RefusalTally` says so (a storm is not a line per request)."""
        if not hasattr(self, "parameter_refusals"):  # made at the first; a managed node keeps it over cleanup
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


#: The node clock in seconds, one reading (:func:`pmv_ros.nodes.rclpy_internals.clock_now_s`).
clock_s = clock_now_s


def _has_reader(publisher, readers: dict | None) -> bool:
    """Whether ``publisher`` has a subscriber: from ``readers`` if it was asked already (then kept there)."""
    if readers is None:
        return publisher.get_subscription_count() > 0
    known = readers.get(publisher)
    if known is None:
        known = readers[publisher] = publisher.get_subscription_count() > 0
    return known


def _publisher_gid(info):
    """The publisher's GID as bytes from rclpy's message info (rclpy ≥ Kilted), None where it has none (Jazzy)."""
    gid = info.get("publisher_gid") if isinstance(info, dict) else None
    if gid is None:
        return None
    try:
        return bytes(gid.get("data", gid) if isinstance(gid, dict) else gid)
    except (TypeError, ValueError):
        return None
