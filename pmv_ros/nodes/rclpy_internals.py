"""Everything pmv_ros does with rclpy's internals, in one place, for one rclpy version, each with a public fallback.

Why this module exists. rclpy's public API does not offer four things the nodes want:

* **the main job's drain** (:func:`drain`): ``pmv simulate`` runs its nodes in one process and, after every
  sensor tick, runs callbacks until its graph is idle. rclpy's executor builds its wait set anew for every
  wait; where the graph holds nothing but subscriptions and timers (the pipeline's lean nodes), this module
  asks the entities directly instead (the executor's task list and shut-down flag, the generator of a wait
  still handing out callbacks, each subscription's callback type, ``take_message`` on its handle, a timer
  handle's readiness) and takes each message as the executor would; :class:`TakingQueued` takes the
  messages queued behind the one a wait handed out, in the same wake-up;
* **one reading of a clock without a** ``Time`` **object** (:func:`clock_now_s`: the clock handle's
  ``get_now``), on every message a node takes;
* **the parameter overrides before** ``declare_parameter`` **sees them** (:func:`parameter_overrides`: the
  node's dictionary of them), so a bad value is refused with the parameter's own reason and an integer is taken
  for a floating-point parameter;
* **a check of /clock messages before rclpy's time source takes them** (:func:`guard_clock`: the time source's
  /clock subscription, its callback wrapped).

Written for rclpy 7.1.5 (ROS 2 Jazzy; the ``ros-jazzy-rclpy`` 7.1.6 wheels carry it): :data:`WRITTEN_FOR`.
Each function here takes the internal path only when the running rclpy is that version (:data:`VERSION_MATCHES`)
and the process has not switched the internals off (:func:`use_internals`; the environment variable
``PMV_ROS_RCLPY_INTERNALS=0`` does so at import). Otherwise it takes its public-API fallback, which does the same
job with rclpy's documented calls, slower or with less (each function says what):

* the drain waits through ``Executor.wait_for_ready_callbacks`` as ``spin_once`` does, one wait per look
  (same messages, same order, same outputs; ≈ 50–70 µs more a wait);
* a :class:`TakingQueued` callback handles its one message; the executor hands out the rest, one per wait;
* the clock is read through ``Clock.now()`` (the same nanoseconds);
* the overrides are checked by rclpy alone as it declares (a wrong type or a value out of range is still
  refused with a reason, from rclpy's words; an integer for a floating-point parameter is refused too);
* /clock reaches rclpy's time source unchecked, as in any rclpy node; the node says so once at start-up.

``tests/nodes/test_rclpy_internals.py`` pins the version: it fails when rclpy's changes, naming what to
re-check, and runs every fallback against its internal path.
"""

from __future__ import annotations

import importlib.metadata
import inspect
import os
import weakref

from rclpy.exceptions import InvalidHandle
from rclpy.executors import TimeoutException
from rclpy.subscription import Subscription

#: The rclpy version this module was written for and tested against.
WRITTEN_FOR = "7.1.5"

#: What the internals are, for the maintainer who updates :data:`WRITTEN_FOR` (the pinning test prints it).
INTERNALS_USED = (
    "Executor._tasks (a list of (task, entity, node); a pending task is handed out before any wait)",
    "Executor._is_shutdown (bool)",
    "Executor._cb_iter (the generator of a wait whose callbacks are still being handed out)",
    "Executor.wait_for_ready_callbacks order: node by node, timers before subscriptions, one message each",
    "Subscription._callback_type (CallbackType.MessageOnly / WithMessageInfo)",
    "Subscription.handle.take_message(msg_type, raw) -> (message, info) or None",
    "Timer.handle.is_timer_ready()",
    "Clock.handle.get_now().nanoseconds",
    "Node._parameter_overrides (name -> Parameter, read by declare_parameter)",
    "Node._time_source._clock_sub (the /clock subscription under use_sim_time; its callback forwards to "
    "TimeSource.clock_callback)",
)


def _installed_rclpy() -> str | None:
    try:
        return importlib.metadata.version("rclpy")
    except importlib.metadata.PackageNotFoundError:
        return None


#: The rclpy version running here (None when its metadata cannot be found: then nothing internal is used).
RCLPY_VERSION = _installed_rclpy()

#: Whether the running rclpy is the one this module was written for.
VERSION_MATCHES = RCLPY_VERSION == WRITTEN_FOR

_state = {"internal": VERSION_MATCHES and os.environ.get("PMV_ROS_RCLPY_INTERNALS", "1") != "0"}


def internals_in_use() -> bool:
    """Whether the functions here take their internal paths now."""
    return _state["internal"]


def use_internals(on: bool) -> None:
    """Switch the internal paths on or off for the whole process (benchmarks and tests compare the two).

    Raises:
        RuntimeError: ``on`` with an rclpy other than :data:`WRITTEN_FOR`.
    """
    if on and not VERSION_MATCHES:
        raise RuntimeError(f"rclpy {RCLPY_VERSION} is not {WRITTEN_FOR}, the version pmv_ros's rclpy internals "
                           "were written for: only the public fallbacks run")
    _state["internal"] = bool(on)


# -- the drain -------------------------------------------------------------------------------------------------


def drain(executor, max_callbacks: int = 100_000, on_idle=None, by_takes: bool = True) -> int:
    """Run an executor's ready callbacks until the graph is idle; returns how many ran.

    With a zero timeout, rclpy's executor ends every wait with a TimeoutException once it has handed out the
    callbacks that wait found (one message per subscription: a second message queued on a subscription needs
    another wait), so a timeout alone does not mean the graph is idle. Idle is two timeouts with no callback
    between them: a wait after the last callbacks that found nothing. ``on_idle()`` is called at every timeout;
    when it says it published something (handing queued inputs over), the graph is not idle yet.

    ``by_takes`` (and the internals in use, :func:`internals_in_use`): where the graph has nothing a wait could
    hand out but subscriptions' messages and timers — no services, clients, guard conditions or other
    waitables, as in the pipeline's lean nodes — each wait is asked of the entities directly
    (:func:`_take_ready`: no task pending, no timer ready, then a take from each subscription in the executor's
    order, one message each), and the messages go to their callbacks in that order, each holding its callback
    group as rclpy's handler does; then that wait's timeout. What a drain cut by ``max_callbacks`` or by an
    exception had not handed out goes first in the next drain, as the rest of a wait does. A ready timer, a
    pending task, a busy callback group (a drain inside a callback), any other entity, a shut-down executor: a
    wait. An async callback is refused (TypeError): the takes do not await it.

    The public fallback (``by_takes`` False, or the internals not in use) is every look a wait of
    ``Executor.wait_for_ready_callbacks`` with a zero timeout and its handler run, as ``spin_once`` runs it.

    One difference remains by construction: rclpy takes each message just before its callback, the takes here
    all before the first. A callback that itself takes from, floods or destroys a later subscription of the same
    look sees that look's messages already taken (none of the pipeline's callbacks does).
    """
    by_takes = by_takes and _state["internal"]
    ran = empty = 0
    look = _OPEN_LOOKS.pop(executor, None)  # a look by takes a drain before left unfinished
    handing_out = look is None and by_takes and _handing_out(executor)  # a wait's callbacks being handed out
    while empty < 2 and ran < max_callbacks:
        if look is None and by_takes and not handing_out:
            look = _take_ready(executor)
        if look is not None:  # a wait by takes: its callbacks, then its timeout
            found = bool(look)
            while look and ran < max_callbacks:
                subscription, taken = look.pop(0)
                try:
                    ran += _hand_over_taken(subscription, taken)
                except BaseException:
                    _OPEN_LOOKS[executor] = look
                    raise
            if ran >= max_callbacks:  # as a wait stopped at a callback: the rest, and its timeout, next time
                _OPEN_LOOKS[executor] = look
                break
            look = None
            empty = 0 if (on_idle is not None and on_idle()) else (1 if found else empty + 1)
            continue
        try:
            handler, _, _ = executor.wait_for_ready_callbacks(timeout_sec=0.0)
        except TimeoutException:
            handing_out = False
            empty = 0 if on_idle is not None and on_idle() else empty + 1
            continue
        handing_out, empty = True, 0
        handler()
        if handler.exception() is not None:
            raise handler.exception()
        ran += 1
    return ran


_WITH_INFO = Subscription.CallbackType.WithMessageInfo

#: Executor → what a look by takes had taken and not yet handed out when its drain stopped (possibly nothing:
#: then only its timeout is still to come).
_OPEN_LOOKS = weakref.WeakKeyDictionary()


def _hand_over_taken(subscription, taken) -> int:
    """One taken message to its subscription's callback, as rclpy's handler does it: not if the subscription was
    destroyed since (0), its callback group held while the callback runs (1). A coroutine a callback returns is
    not awaited here: TypeError."""
    try:
        with subscription.handle:
            pass
    except InvalidHandle:  # destroyed by an earlier callback of the look (or with its node)
        return 0
    group = subscription.callback_group
    group.beginning_execution(subscription)  # a drain inside the callback: its group is busy (_take_ready)
    try:
        result = subscription.callback(*(taken if subscription._callback_type is _WITH_INFO else taken[:1]))
    finally:
        group.ending_execution(subscription)
    if inspect.iscoroutine(result):
        result.close()
        raise TypeError(f"{subscription.topic_name}: an async callback; drain(by_takes=False) awaits it")
    return 1


def _handing_out(executor) -> bool:
    """Whether a wait of ``executor`` still holds callbacks it has not handed out (a drain stopped by its callback
    limit or an exception left it so): the executor's generator of them is suspended."""
    waiting = getattr(executor, "_cb_iter", None)
    return waiting is not None and inspect.getgeneratorstate(waiting) == inspect.GEN_SUSPENDED


def _take_ready(executor) -> list | None:
    """What a zero-timeout wait of ``executor`` would hand out now, where that is only subscriptions' messages:
    ``(subscription, taken)`` in the executor's order (node by node; one message per subscription), [] when
    there is nothing; None where only a wait can tell — a shut-down executor, a timer ready (the executor runs a
    node's timers before its subscriptions), a task pending (it comes first), a callback group busy, or a node
    with an entity the takes cannot see. Each message is taken as rclpy's executor takes it."""
    if executor._is_shutdown or not executor.context.ok():
        return None
    if any(not task.done() for task, _, _ in executor._tasks):  # the handlers it made keep a place till it waits
        return None
    nodes = executor.get_nodes()
    subscriptions = []
    for node in nodes:
        for entities in (node.services, node.clients, node.guards, node.waitables):  # generators: asked for one
            if next(entities, None) is not None:
                return None
        for timer in node.timers:
            if timer.handle.is_timer_ready():
                return None
        for subscription in node.subscriptions:
            if not subscription.callback_group.can_execute(subscription):
                return None
            subscriptions.append(subscription)
    ready = []
    for subscription in subscriptions:
        taken = _take(subscription)
        if taken is not None:
            ready.append((subscription, taken))
    return ready


def _take(subscription):
    """One message of ``subscription`` as rclpy's executor takes it: ``(message, info)``, or None when none is
    queued or the subscription is destroyed."""
    try:
        with subscription.handle:
            return subscription.handle.take_message(subscription.msg_type, subscription.raw)
    except InvalidHandle:
        return None


class TakingQueued:
    """A subscription's callback that, in the wake-up the executor hands it one message, also takes the messages
    queued behind it (at most ``depth``), each to ``callback(message)`` in order.

    rclpy's executor takes one message per subscription per wait, and a wait costs ≈ 65 µs of rclpy's own Python
    (its wait set is built anew): the five residuals the monitor publishes when a star-tracker frame settles its
    samples would cost the main job five waits. Each further message is taken as rclpy's executor takes one and
    handed over outside it: a subscription destroyed meanwhile ends the loop. Public fallback: only the message
    handed out (the executor hands the others out, one a wait). For message-only callbacks (the message info is
    not passed on) in the node's default, mutually exclusive callback group.

    Make it first and give it to ``create_subscription`` as the callback; then set :attr:`subscription` to what
    that returned (:func:`taking_queued` does both). ``callback`` is an attribute (a benchmark counts the takes
    through it).
    """

    def __init__(self, subscription, callback, depth: int = 100):
        inspect.signature(callback).bind(None)  # a TypeError now for a callback that wants the message info too
        self.subscription, self.callback, self.depth = subscription, callback, depth

    def __call__(self, message) -> None:
        self.callback(message)
        if not _state["internal"] or self.subscription is None:
            return
        for _ in range(self.depth):
            taken = _take(self.subscription)
            if taken is None:
                return
            self.callback(taken[0])


def taking_queued(make_subscription, callback, depth: int) -> object:
    """A subscription made by ``make_subscription(callback)`` whose callback is a :class:`TakingQueued` of
    ``callback``; returns the subscription."""
    taker = TakingQueued(None, callback, depth)
    subscription = make_subscription(taker)
    taker.subscription = subscription
    return subscription


# -- the clock ---------------------------------------------------------------------------------------------------


def clock_now_s(clock) -> float:
    """``clock.now()`` in seconds, read as rclpy reads it (its handle's ``get_now``) but without the ``Time`` it
    builds (≈ 1.4 µs less of every message a node takes). Fallback: ``clock.now()``; the same nanoseconds."""
    if _state["internal"]:
        handle = clock.handle
        with handle:
            return handle.get_now().nanoseconds * 1e-9
    return clock.now().nanoseconds * 1e-9


# -- parameters --------------------------------------------------------------------------------------------------


def parameter_overrides(node) -> dict | None:
    """The node's parameter overrides (command line, params files, ``parameter_overrides``) as rclpy keeps them for
    ``declare_parameter``: ``{name: Parameter}``, the very dictionary (a value replaced here is the one declared).
    None in the fallback: rclpy alone checks them as it declares."""
    if not _state["internal"]:
        return None
    return node._parameter_overrides


# -- /clock ------------------------------------------------------------------------------------------------------


def guard_clock(node, admit, guarded=None):
    """Put ``admit(message, info) -> bool`` in front of rclpy's /clock callback of ``node``: a message it refuses
    never reaches the time source. rclpy's subscription is kept (rclpy removes it when ``use_sim_time`` goes off).

    ``guarded``: the subscription guarded before (None at first). Returns the subscription guarded now (the same
    one when nothing changed; None while ``use_sim_time`` is off, or in the fallback, where /clock reaches rclpy's
    time source unchecked)."""
    if not _state["internal"]:
        return None
    time_source = node._time_source
    subscription = time_source._clock_sub
    if subscription is None or subscription is guarded:
        return subscription
    forward = time_source.clock_callback

    def on_clock(message, info) -> None:
        if admit(message, info):
            forward(message)

    subscription.callback = on_clock
    return subscription
