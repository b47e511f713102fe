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
* cleanup, shutdown — everything configure made is destroyed. Declared parameters
  stay declared with their values (rclpy has no public way to undeclare a
  read-only one); a new configure checks them again and builds anew.

What the node makes after configure (a timer rebuilt for a new rate) joins what cleanup destroys and is held
still while the node is inactive.
"""

from __future__ import annotations

import inspect
import sys

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
        LifecycleNode.__init__(self, self.node_name, **node_arguments)
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
        """Destroy what configure made and remove its parameter callbacks: back to unconfigured."""
        self.on_deactivate(state)
        self._held = {}
        for kind, destroy in _ENTITY_KINDS:
            for entity in self._made(kind):
                getattr(self, destroy)(entity)
        for remover, callback in self._parameter_callbacks:
            try:
                getattr(self, remover)(callback)
            except ValueError:  # already removed
                pass
        self._parameter_callbacks = []
        self.configured = False
        return _SUCCESS

    on_cleanup = on_shutdown = on_error = _release

    # -- what configure makes is gated from the start: silent until activation ---------------------

    @staticmethod
    def _hold_still(timer) -> None:
        if not timer.is_canceled():
            timer.cancel()
            timer._held_still = True  # started again at activation

    def create_publisher(self, *args, **kwargs):
        publisher = super().create_publisher(*args, **kwargs)
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

    def create_subscription(self, *args, **kwargs):
        subscription = super().create_subscription(*args, **kwargs)
        if self.configuring or self.configured:
            callback = subscription.callback

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
