"""Managed (lifecycle) variants of the pmv_ros nodes: ``--managed`` on the command line, ``managed:=true`` in launch.

:class:`ManagedNode` is rclpy's ``LifecycleNodeMixin`` on a :class:`~pmv_ros.nodes.base.PmvNode`, as rclpy's own
``LifecycleNode`` is the mixin on ``Node``; each node module declares its managed class
(``ManagedSensorNode(ManagedNode, SensorNode)``). One node of the node's own name in the graph, with the
standard lifecycle services (``<node>/change_state``, ``<node>/get_state``, …, ``<node>/transition_event``) and,
once configured, the node's parameters on its own parameter services. It uses the node's interface of
configuration (:class:`~pmv_ros.nodes.base.PmvNode`: :meth:`~pmv_ros.nodes.base.PmvNode.build` and the
``make_*`` methods) and rclpy's public lifecycle API (lifecycle publishers, ``add_managed_entity``, the
``on_*`` transition callbacks); nothing else.

* construction — only the node itself and its lifecycle services: no file is
  read, no parameter declared, nothing published or subscribed;
* configure — the node's configuration is built (:meth:`~pmv_ros.nodes.base.PmvNode.build`): it declares and
  checks the parameters, reads the files, builds the models and makes its publishers (lifecycle publishers),
  subscriptions, timers and wake-up guard (its declared topics), all held still.
  A failure (a bad ``sensor.correction`` file, a value out of range) leaves it
  unconfigured, with what was made released and the reason logged (also on
  /rosout) and kept in :attr:`ManagedNode.configure_error`;
* activate — its timers run and its subscriptions deliver; it publishes;
* deactivate — its timers stop; a message that arrives meanwhile is dropped, not
  processed late; nothing is published (a latched, transient-local message made
  while inactive goes out at the next activation);
* cleanup — everything configure made is released: timers and the wake-up guard
  destroyed, publishers and subscriptions silenced and, after
  :data:`PARKED_S` of wall time without a configure, destroyed. A configure
  within that time takes back those it declares again (same topic, type and
  QoS) instead of making new ones: a neighbour flapping transitions does not
  make the node create and destroy DDS endpoints at its rate (Fast DDS 2.14
  crashed in a receive thread under that: see the managed-nodes documentation);
* shutdown, error — everything configure made is destroyed at once. Declared
  parameters stay declared with their values (rclpy has no public way to
  undeclare a read-only one); a new configure checks them again and builds anew.

What the node makes after configure (a timer rebuilt for a new rate) joins what cleanup destroys and is held
still while the node is inactive.

A ``change_state`` request for a transition the current state does not have (``activate`` while unconfigured)
is refused by rclpy's state machine, but rclpy 7.1 raises that refusal out of its service instead of answering
``success = false`` (rclpy issue 1209): the requester gets no answer. :func:`pmv_ros.nodes.launch.run_node` keeps
the node running and logs the refusal; ``ros2 lifecycle set`` asks for the available transitions first and
never sends one.
"""

from __future__ import annotations

import inspect
import sys

from rclpy.clock import Clock, ClockType
from rclpy.lifecycle import LifecycleNodeMixin, LifecyclePublisher, State, TransitionCallbackReturn
from rclpy.qos import DurabilityPolicy

from .base import PmvNode
from .params import ParameterError

#: The command-line switch (before ``--ros-args``) that starts a node as a managed node.
MANAGED_FLAG = "--managed"

#: How long (s, wall clock) cleanup keeps the publishers and subscriptions of a configuration, silent, for a
#: configure that declares them again; then they are destroyed.
PARKED_S = 1.0


def managed_requested(args=None) -> bool:
    """True when ``--managed`` is among the node's own arguments (those before ``--ros-args``)."""
    argv = list(sys.argv[1:] if args is None else args)
    if "--ros-args" in argv:
        argv = argv[:argv.index("--ros-args")]
    return MANAGED_FLAG in argv


class HoldingLifecyclePublisher(LifecyclePublisher):
    """A lifecycle publisher that, on a transient-local (latched) topic, keeps the last message published while
    inactive and publishes it at activation (a late subscriber is owed the last message); on other topics, as
    rclpy's: what is published while inactive is dropped."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.held_message = None
        self.latched = self.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL

    def publish(self, message) -> None:
        if self.is_activated:
            super().publish(message)
        elif self.latched:
            self.held_message = message

    def on_activate(self, state) -> TransitionCallbackReturn:
        result = super().on_activate(state)
        held, self.held_message = self.held_message, None
        if held is not None:
            self.publish(held)
        return result


class _Gate:
    """A subscription's callback that passes a message to ``target`` while the node is active and drops it
    otherwise; the target is the current configuration's callback (a configure taking the subscription back
    sets it anew). One message argument."""

    def __init__(self, node: ManagedNode, target):
        self.node, self.target = node, target

    def __call__(self, message) -> None:
        if self.node.is_active:
            self.target(message)


class _GateWithInfo(_Gate):
    """:class:`_Gate` for a callback that takes the message info too."""

    def __call__(self, message, info) -> None:
        if self.node.is_active:
            self.target(message, info)


def _takes_info(callback) -> bool:
    """Whether rclpy passes ``callback`` the message info (it binds two arguments)."""
    try:
        inspect.signature(callback).bind(None)
        return False
    except TypeError:
        return True


class _Configuration:
    """What one configuration made, by kind; and its set-parameters callbacks."""

    def __init__(self):
        self.publishers, self.subscriptions, self.timers, self.guards, self.parameter_checks = [], [], [], [], []


class ManagedNode(LifecycleNodeMixin, PmvNode):
    """A :class:`~pmv_ros.nodes.base.PmvNode` as a managed (lifecycle) node: see the module docstring.

    Construct it with the node class's keyword arguments: those of :meth:`~pmv_ros.nodes.base.PmvNode.build`
    are kept for each configure, the others make the node (``context``, ``parameter_overrides``, …).
    """

    def __init__(self, **arguments):
        self.configured = self.is_active = False
        self.configure_error = None  # why the last configure failed
        self._configuration = _Configuration()
        self._parked = []  # (kind, entity): publishers and subscriptions cleanup silenced, for a configure
        self._held_timers = set()  # timers cancelled while inactive, started again at activation
        PmvNode.__init__(self, **arguments)  # then begin(): the arguments of build are kept for configure
        LifecycleNodeMixin.__init__(self)
        self._parked_expiry = self.create_timer(PARKED_S, self._destroy_parked,
                                                clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._parked_expiry.cancel()  # started by each cleanup

    def begin(self, arguments: dict) -> None:
        """Construction ends unconfigured: the arguments of build wait for a configure."""
        self._build_arguments = arguments

    def configuration_endpoints(self) -> list:
        """The publishers and subscriptions configure made that the node holds: the current configuration's and
        the parked ones of the last (none once they are destroyed)."""
        current = self._configuration
        return [*current.publishers, *current.subscriptions, *(entity for _, entity in self._parked)]

    # -- transitions ----------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        self._configuration = _Configuration()
        try:
            self.configure_node(self._build_arguments)
        except Exception as error:  # a bad value or file; anything else too: what was made is released
            expected = isinstance(error, (ParameterError, ValueError, OSError))
            self.configure_error = str(error) if expected else f"{type(error).__name__}: {error}"
            self._release(park=False)
            self._destroy_parked()
            self.get_logger().error(f"configure failed, still unconfigured: {self.configure_error}")
            return TransitionCallbackReturn.FAILURE
        self.configure_error, self.configured = None, True
        self._destroy_parked()  # what this configuration did not declare again
        return super().on_configure(state)

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self.is_active = True
        result = super().on_activate(state)  # the lifecycle publishers: enabled, a held latched message sent
        for timer in self._held_timers & set(self.timers):
            timer.reset()
        self._held_timers.clear()
        return result

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        if self.is_active and self._queued:  # what a batching node took while active goes through first
            self.flush_inputs()
        self.is_active = False
        for timer in self._live_timers():
            self._hold_still(timer)
        return super().on_deactivate(state)

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        """What configure made is released; its publishers and subscriptions are parked for :data:`PARKED_S`."""
        self._release(park=True)
        self._parked_expiry.reset()
        return super().on_cleanup(state)

    def on_shutdown(self, state: State) -> TransitionCallbackReturn:
        """What configure made is destroyed at once (from any primary state)."""
        self._release(park=False)
        self._destroy_parked()
        return super().on_shutdown(state)

    def on_error(self, state: State) -> TransitionCallbackReturn:
        """As :meth:`on_shutdown`: back to unconfigured with nothing made."""
        self._release(park=False)
        self._destroy_parked()
        return super().on_error(state)

    def _release(self, park: bool) -> None:
        """Release what the configuration made: the publishers and subscriptions parked (``park``) or destroyed,
        the timers and guards destroyed, its set-parameters callbacks removed; unconfigured."""
        if self.is_active:
            self.on_deactivate(None)
        made, self._configuration = self._configuration, _Configuration()
        for publisher in made.publishers:
            publisher.held_message = None
            if park:
                self._parked.append(("publisher", publisher))
            else:
                self.destroy_lifecycle_publisher(publisher)
        for subscription in made.subscriptions:
            subscription.callback.target = None
            if park:
                self._parked.append(("subscription", subscription))
            else:
                self.destroy_subscription(subscription)
        for timer in self._live_timers(made):
            self.destroy_timer(timer)
        for guard in made.guards:
            self.destroy_guard_condition(guard)
        for callback in made.parameter_checks:
            self.remove_on_set_parameters_callback(callback)
        self._held_timers.clear()
        self.configured = False

    def _destroy_parked(self) -> None:
        """Destroy the parked publishers and subscriptions no configure took back."""
        self._parked_expiry.cancel()
        parked, self._parked = self._parked, []
        for kind, entity in parked:
            if kind == "publisher":
                self.destroy_lifecycle_publisher(entity)
            else:
                self.destroy_subscription(entity)

    def _unpark(self, kind: str, key: tuple):
        """The parked entity of ``kind`` with this ``key`` (type, resolved topic, QoS[, whether its callback
        takes the message info]), taken out of the park; None if there is none."""
        for k, (parked_kind, entity) in enumerate(self._parked):
            if parked_kind == kind and self._park_key(kind, entity) == key:
                return self._parked.pop(k)[1]
        return None

    @staticmethod
    def _park_key(kind: str, entity) -> tuple:
        key = (entity.msg_type, entity.topic_name, entity.qos_profile)
        return key + (isinstance(entity.callback, _GateWithInfo),) if kind == "subscription" else key

    # -- what a configuration makes (PmvNode's make_* methods): silent until activation ----------------

    def _live_timers(self, configuration: _Configuration | None = None) -> list:
        """The timers of ``configuration`` (the current one) not destroyed since (a rate change replaces one)."""
        alive = set(self.timers)
        return [timer for timer in (configuration or self._configuration).timers if timer in alive]

    def _hold_still(self, timer) -> None:
        if not timer.is_canceled():
            timer.cancel()
            self._held_timers.add(timer)

    def make_publisher(self, message_type, topic: str, qos, **options):
        """A lifecycle publisher (:class:`HoldingLifecyclePublisher`): a parked one of the same topic, type and
        QoS if there is one (a call with more options than the event callbacks makes a new one)."""
        publisher = None
        if not set(options) - {"event_callbacks"}:
            publisher = self._unpark("publisher", (message_type, self.resolve_topic_name(topic), qos))
        if publisher is None:
            publisher = self.create_publisher(message_type, topic, qos, publisher_class=HoldingLifecyclePublisher,
                                              **options)
            self.add_managed_entity(publisher)
            if self.is_active:  # made while active (after configure): enabled at once
                publisher.on_activate(None)
        self._configuration.publishers.append(publisher)
        return publisher

    def make_subscription(self, message_type, topic: str, callback, qos, **options):
        """A subscription whose messages reach ``callback`` only while the node is active: a parked one of the
        same topic, type, QoS and callback arity if there is one (a call with more options than the event
        callbacks makes a new one)."""
        gate_class = _GateWithInfo if _takes_info(callback) else _Gate
        subscription = None
        if not set(options) - {"event_callbacks"}:
            subscription = self._unpark("subscription", (message_type, self.resolve_topic_name(topic), qos,
                                                         gate_class is _GateWithInfo))
        if subscription is None:
            subscription = self.create_subscription(message_type, topic, gate_class(self, callback), qos, **options)
        else:
            subscription.callback.target = callback
        self._configuration.subscriptions.append(subscription)
        return subscription

    def make_timer(self, period_s: float, callback, clock=None):
        """A timer, held still while the node is inactive."""
        timer = self.create_timer(period_s, callback, clock=clock)
        self._configuration.timers.append(timer)
        if not self.is_active:
            self._hold_still(timer)
        return timer

    def make_guard_condition(self, callback):
        guard = self.create_guard_condition(callback)
        self._configuration.guards.append(guard)
        return guard

    def add_parameter_check(self, callback) -> None:
        self.add_on_set_parameters_callback(callback)
        self._configuration.parameter_checks.append(callback)
