"""Managed (lifecycle) variants of the pmv_ros nodes: ``--managed`` on the command line, ``managed:=true`` in the launch.

A :class:`ManagedNode` is a ``rclpy.lifecycle.LifecycleNode`` of the node's
own name with the standard lifecycle services (``<node>/change_state``,
``<node>/get_state``, …) and no parameter services of its own. It hosts the
plain node, unchanged:

* configure — builds the plain node (reads the files, builds the models,
  declares and checks the parameters). A failure (a bad ``sensor.correction``
  file, a value out of range) leaves it unconfigured and logs the reason (also
  on /rosout);
* activate — the plain node joins the executor: its timers and subscriptions
  run, it publishes;
* deactivate — it leaves the executor: no callback runs, nothing is published
  (its publishers and subscriptions stay; messages that arrive meanwhile are
  dropped at activation, not processed late);
* cleanup, shutdown — the plain node is destroyed with everything it made.

While configured, the hosted node is a second node of the same name in the
graph (it carries the parameters and the parameter services); the host only
carries the lifecycle services.
"""

from __future__ import annotations

import sys

from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.lifecycle import LifecycleNode, State, TransitionCallbackReturn

from .params import ParameterError

RCLError = rclpy_implementation.RCLError

#: The command-line switch (before ``--ros-args``) that starts a node as a managed node.
MANAGED_FLAG = "--managed"


def managed_requested(args=None) -> bool:
    """True when ``--managed`` is among the node's own arguments (those before ``--ros-args``)."""
    argv = list(sys.argv[1:] if args is None else args)
    if "--ros-args" in argv:
        argv = argv[:argv.index("--ros-args")]
    return MANAGED_FLAG in argv


class ManagedNode(LifecycleNode):
    """A lifecycle node hosting a plain pmv_ros node, built at configure and destroyed at cleanup.

    Args:
        factory: makes the plain node (``SensorNode``, …); called with ``context`` and ``node_arguments``.
        name: the node's name (the plain node's own).
        node_arguments: further keyword arguments for ``factory`` (``parameter_overrides`` in tests).
    """

    def __init__(self, factory, name: str, *, context=None, **node_arguments):
        super().__init__(name, context=context, start_parameter_services=False)
        self._factory, self._context, self._arguments = factory, context, node_arguments
        self.inner = None
        self.configure_error = None  # why the last configure failed
        # rclpy raises out of the change_state service for a transition the current state does not have (and so
        # ends the spin): refused here with success = false and a warning, like a transition that failed.
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

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        try:
            # Its logs reach /rosout through the host's publisher (same logger name); a /rosout publisher of its
            # own would be unregistered with it at cleanup, and the host's logs would go silent.
            self.inner = self._factory(context=self._context, enable_rosout=False, **self._arguments)
        except (ParameterError, ValueError, OSError) as error:
            self.configure_error = str(error)
            self.get_logger().error(f"configure failed, still unconfigured: {error}")
            return TransitionCallbackReturn.FAILURE
        self.configure_error = None
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: State) -> TransitionCallbackReturn:
        if self.executor is None:  # a transition triggered in-process on a node nothing spins
            self.get_logger().error("activate failed: the node is not in an executor")
            return TransitionCallbackReturn.FAILURE
        self._discard_pending()
        self.executor.add_node(self.inner)
        return TransitionCallbackReturn.SUCCESS

    def on_deactivate(self, state: State) -> TransitionCallbackReturn:
        self._leave_executor()
        return TransitionCallbackReturn.SUCCESS

    def on_cleanup(self, state: State) -> TransitionCallbackReturn:
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: State) -> TransitionCallbackReturn:
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def on_error(self, state: State) -> TransitionCallbackReturn:
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self):
        self._release()
        return super().destroy_node()

    def _discard_pending(self) -> None:
        """Drop what the inactive node's subscriptions received meanwhile: an activated node starts fresh."""
        for subscription in self.inner.subscriptions:
            while True:
                try:
                    if subscription.handle.take_message(subscription.msg_type, subscription.raw) is None:
                        break
                except Exception:  # nothing to take, or a message that cannot be taken: stop draining
                    break

    def _leave_executor(self) -> None:
        executor = self.executor
        if self.inner is not None and executor is not None and self.inner in executor.get_nodes():
            executor.remove_node(self.inner)

    def _release(self) -> None:
        if self.inner is None:
            return
        self._leave_executor()
        inner, self.inner = self.inner, None
        inner.destroy_node()


def managed_factory(factory, name: str):
    """``factory`` as a managed node for :func:`pmv_ros.nodes.launch.run_node` (the global context)."""
    return lambda: ManagedNode(factory, name)
