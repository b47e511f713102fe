"""Managed (lifecycle) variants of the pmv_ros nodes: ``--managed`` on the command line, ``managed:=true`` in the launch.

:func:`managed` makes one class of a node class and ``rclpy.lifecycle.LifecycleNode``:
one node of the node's own name in the graph, with the standard lifecycle
services (``<node>/change_state``, ``<node>/get_state``, …) and, once
configured, the node's parameters on its own parameter services.

* construction — only the node itself and its lifecycle services: no file is
  read, no parameter declared, nothing published or subscribed;
* configure — the node's own constructor runs on it: it declares and checks the
  parameters, reads the files, builds the models and makes its publishers,
  subscriptions, timers and wake-up guard (its declared topics), all held still.
  A failure (a bad ``sensor.correction`` file, a value out of range) leaves it
  unconfigured, with what was made released and the reason logged (also on
  /rosout) and kept in :attr:`configure_error`;
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
  once crashed in a receive thread under that, README "Managed nodes");
* shutdown, error — everything configure made is destroyed at once. Declared
  parameters stay declared with their values (rclpy has no public way to
  undeclare a read-only one); a new configure checks them again and builds anew.

What the node makes after configure (a timer rebuilt for a new rate) joins what cleanup destroys and is held
still while the node is inactive.
"""

from __future__ import annotations

import inspect
import sys

from rclpy.clock import Clock, ClockType
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.lifecycle import LifecycleNode, State, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy

from .params import ParameterError

RCLError = rclpy_implementation.RCLError

#: The command-line switch (before ``--ros-args``) that starts a node as a managed node.
MANAGED_FLAG = "--managed"

#: The keyword arguments that make the rclpy node itself (given at construction); the others are the
#: node class's own (``lean``, ``external_drive``, …) and reach its constructor at configure.
_NODE_KEYWORDS = frozenset(inspect.signature(Node.__init__).parameters) - {"self", "node_name"}

#: What configure makes, by kind, and how each kind is released at cleanup.
_ENTITY_KINDS = (("publishers", "destroy_publisher"), ("subscriptions", "destroy_subscription"),
                 ("timers", "destroy_timer"), ("clients", "destroy_client"), ("services", "destroy_service"),
                 ("guards", "destroy_guard_condition"))

#: How long (s, wall clock) cleanup keeps the publishers and subscriptions of a configuration, silent, for a
#: configure that declares them again; then they are destroyed.
PARKED_S = 1.0

#: What cleanup parks instead of destroying (the DDS endpoints).
_PARKED_KINDS = ("publishers", "subscriptions")

_SUCCESS = TransitionCallbackReturn.SUCCESS


def managed_requested(args=None) -> bool:
    """True when ``--managed`` is among the node's own arguments (those before ``--ros-args``)."""
    argv = list(sys.argv[1:] if args is None else args)
    if "--ros-args" in argv:
        argv = argv[:argv.index("--ros-args")]
    return MANAGED_FLAG in argv


class _Managed:
    """The lifecycle half of a managed node class (see :func:`managed`); comes first in its MRO."""

    node_name = ""  # set by managed()

    def __init__(self, **arguments):
        node_arguments = {key: value for key, value in arguments.items() if key in _NODE_KEYWORDS}
        self._own_arguments = {key: value for key, value in arguments.items() if key not in _NODE_KEYWORDS}
        self.configuring = False  # PmvNode.__init__ then builds on this node instead of making one
        self.configured = self.active = False
        self.configure_error = None  # why the last configure failed
        self._parameter_callbacks = []  # (remove method name, callback) added by configure
        self._held = {}  # transient-local publisher → its last message made while inactive
        # What PmvNode.__init__ sets before anything can call it: the parameter services (the type gate) and
        # destroy_node work on an unconfigured node too.
        self.parameter_specs, self._detached = {}, []
        self._parked = []  # (kind, entity): the publishers and subscriptions cleanup silenced, for a configure
        LifecycleNode.__init__(self, self.node_name, **node_arguments)
        self._parked_expiry = self.create_timer(PARKED_S, self._destroy_parked,
                                                clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._parked_expiry.cancel()  # started by each cleanup
        # The lifecycle node's own entities: everything else is configure's (or later changes') and goes at cleanup.
        self._own = {kind: set(getattr(self, kind)) for kind, _ in _ENTITY_KINDS}
        # rclpy raises out of the change_state service for a transition the current state does not have (and so
        # ends the spin): refused here with success = false and a warning, like a transition that failed.
        # (LifecycleNode has no public accessor for the service: its attribute is used.)
        service = self._service_change_state
        change_state = service.callback

        def guarded_change_state(request, response):
            try:
                return change_state(request, response)
            except RCLError as error:
                self.get_logger().warning(f"transition {request.transition.id} {request.transition.label!r} "
                                          f"refused: {error}")
                response.success = False
                return response

        service.callback = guarded_change_state

    def _made(self, kind: str) -> list:
        """The entities of ``kind`` configure (and later changes) made."""
        return [entity for entity in getattr(self, kind) if entity not in self._own[kind]]

    # -- transitions ----------------------------------------------------------------------------

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        self.configuring = True
        try:
            super().__init__(**self._own_arguments)  # the node class's constructor, on this node
        except Exception as error:  # a bad value or file; anything else too: what was made is released
            expected = isinstance(error, (ParameterError, ValueError, OSError))
            self.configure_error = str(error) if expected else f"{type(error).__name__}: {error}"
            self._release(state)
            self.get_logger().error(f"configure failed, still unconfigured: {self.configure_error}")
            return TransitionCallbackReturn.FAILURE
        finally:
            self.configuring = False
        self.configure_error, self.configured = None, True
        self._destroy_parked()  # what this configuration did not declare again
        return self.on_deactivate(state)  # configured, inactive: timers stopped (the rest is gated as it is made)

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        self.active = True
        for publisher, message in list(self._held.items()):
            if publisher in self.publishers:
                publisher.publish(message)
        self._held.clear()
        for timer in self._made("timers"):
            if getattr(timer, "_held_still", False):
                timer._held_still = False
                timer.reset()
        return _SUCCESS

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        if self.active and self._queued:  # what a batching node took while active goes through first
            self.flush_inputs()
        self.active = False
        for timer in self._made("timers"):
            self._hold_still(timer)
        return _SUCCESS

    def _release(self, state: State) -> TransitionCallbackReturn:
        """Destroy what configure made and remove its parameter callbacks: back to unconfigured (shutdown, error)."""
        self._release_made(park=False)
        self._destroy_parked()
        return _SUCCESS

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        """As :meth:`_release`, but the publishers and subscriptions are parked for :data:`PARKED_S`."""
        self._release_made(park=True)
        self._parked_expiry.reset()
        return _SUCCESS

    def _release_made(self, park: bool) -> None:
        self.on_deactivate(None)
        self._held = {}
        parked = {id(entity) for _, entity in self._parked}
        for kind, destroy in _ENTITY_KINDS:
            for entity in self._made(kind):
                if id(entity) in parked:
                    continue
                if park and kind in _PARKED_KINDS:
                    self._parked.append((kind, entity))
                else:
                    getattr(self, destroy)(entity)
        for remover, callback in self._parameter_callbacks:
            try:
                getattr(self, remover)(callback)
            except ValueError:  # already removed
                pass
        self._parameter_callbacks = []
        self.configured = False

    def _destroy_parked(self) -> None:
        """Destroy the parked publishers and subscriptions no configure took back."""
        self._parked_expiry.cancel()
        parked, self._parked = self._parked, []
        for kind, entity in parked:
            getattr(self, dict(_ENTITY_KINDS)[kind])(entity)

    def _unpark(self, kind: str, message_type, topic: str, qos, options: dict):
        """The parked entity of ``kind`` with this type, topic and QoS, taken out of the park; None if there is
        none (or the call asks for more than those: a callback group, QoS overrides, raw messages)."""
        if not self.configuring or set(options) - {"event_callbacks"}:
            return None
        resolved = self.resolve_topic_name(topic)
        for k, (parked_kind, entity) in enumerate(self._parked):
            if (parked_kind, entity.msg_type, entity.topic_name, entity.qos_profile) == (kind, message_type,
                                                                                         resolved, qos):
                return self._parked.pop(k)[1]
        return None

    on_shutdown = on_error = _release

    # -- what configure makes is gated from the start: silent until activation ---------------------

    @staticmethod
    def _hold_still(timer) -> None:
        if not timer.is_canceled():
            timer.cancel()
            timer._held_still = True  # started again at activation

    def create_publisher(self, msg_type, topic, qos_profile, **options):
        parked = self._unpark("publishers", msg_type, topic, qos_profile, options)
        if parked is not None:
            return parked  # gated already, on this node
        publisher = super().create_publisher(msg_type, topic, qos_profile, **options)
        if self.configuring or self.configured:
            publish = publisher.publish
            latched = publisher.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL

            def gated(message) -> None:
                if self.active:
                    publish(message)
                elif latched:
                    self._held[publisher] = message

            publisher.publish = gated
        return publisher

    def create_subscription(self, msg_type, topic, callback, qos_profile, **options):
        subscription = self._unpark("subscriptions", msg_type, topic, qos_profile, options)
        if subscription is None:
            subscription = super().create_subscription(msg_type, topic, callback, qos_profile, **options)
        if self.configuring or self.configured:

            def gated(*message_and_info) -> None:
                if self.active:
                    callback(*message_and_info)

            gated.__signature__ = inspect.signature(callback)  # rclpy passes the info as the callback wants it
            subscription.callback = gated
        return subscription

    def create_timer(self, *args, **kwargs):
        timer = super().create_timer(*args, **kwargs)
        if self.configured and not self.configuring and not self.active:
            self._hold_still(timer)
        return timer

    # -- parameter callbacks added while configuring are removed at cleanup ---------------------

    def add_on_set_parameters_callback(self, callback):
        self._note_parameter_callback("remove_on_set_parameters_callback", callback)
        return super().add_on_set_parameters_callback(callback)

    def add_pre_set_parameters_callback(self, callback):
        self._note_parameter_callback("remove_pre_set_parameters_callback", callback)
        return super().add_pre_set_parameters_callback(callback)

    def add_post_set_parameters_callback(self, callback):
        self._note_parameter_callback("remove_post_set_parameters_callback", callback)
        return super().add_post_set_parameters_callback(callback)

    def _note_parameter_callback(self, remover: str, callback) -> None:
        if self.configuring:
            self._parameter_callbacks.append((remover, callback))


def managed(node_class, name: str):
    """``node_class`` (a :class:`pmv_ros.nodes.base.PmvNode`) as a lifecycle node class named ``name``.

    Construct it with the node class's keyword arguments; those of ``rclpy.node.Node`` (``context``,
    ``parameter_overrides``, …) make the node, the others reach the node class's constructor at configure.
    """
    return type(f"Managed{node_class.__name__}", (_Managed, node_class, LifecycleNode),
                {"node_name": name, "__doc__": f"{node_class.__name__} as a managed (lifecycle) node."})
