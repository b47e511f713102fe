"""One ``main`` for every node executable: start, spin, stop cleanly, fail cleanly on bad configuration."""

from __future__ import annotations

import os
import signal
import sys
import warnings

import rclpy
import rclpy.logging
from rclpy.exceptions import NameValidationException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.signals import SignalHandlerOptions

from .managed import managed_requested
from .params import ParameterError, check_params_files

try:  # no rosdep key (package.xml): a ROS workspace may not have it
    from threadpoolctl import ThreadpoolController
except ImportError:
    ThreadpoolController = None

#: Exit status of a node whose command line rclpy refuses (an unknown ROS argument, a namespace, node name or
#: remap that is too long or malformed): a usage error, as the CLI's.
USAGE_STATUS = 2

#: Longest wait of the executor between checks for a stop request, s.
STOP_CHECK_S = 0.1

_STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)

#: A node's own argument (before ``--ros-args``): stop as on SIGINT when the process that started it is gone.
#: ``ros2 launch`` ends on SIGTERM without stopping its children (launch's own behaviour); the launch file gives
#: its nodes this flag so that they do not run on as orphans.
STOP_WITH_PARENT_FLAG = "--stop-with-parent"

_blas = {"holders": 0, "limiter": None}

#: What a process logs once when it cannot hold BLAS to one thread.
NO_THREADPOOLCTL = ("threadpoolctl cannot be imported (pip install threadpoolctl): BLAS keeps its own threads, which "
                    "on a machine of few cores contend with the executor and DDS")


def hold_single_threaded_blas() -> None:
    """Run BLAS on one thread in this process until the last holder releases it.

    The nodes' products are small; left to itself OpenBLAS splits them over every core, where on a 2-core machine
    its threads contend with the executor and DDS (a block of sensor samples took 4–10× longer). Holders are
    counted: overlapping pipelines restore the original setting only when the last is released.
    """
    if _blas["holders"] == 0:
        if ThreadpoolController is not None:
            _blas["limiter"] = ThreadpoolController().limit(limits=1, user_api="blas")
        elif not _blas.get("warned"):
            rclpy.logging.get_logger("pmv_ros").warning(NO_THREADPOOLCTL)
            _blas["warned"] = True
    _blas["holders"] += 1


def release_single_threaded_blas() -> None:
    """Undo one :func:`hold_single_threaded_blas`; the last release restores the original BLAS threads."""
    if _blas["holders"]:
        _blas["holders"] -= 1
        if _blas["holders"] == 0 and _blas["limiter"] is not None:
            _blas["limiter"].restore_original_limits()


class StopRequest:
    """SIGINT and SIGTERM ask the spin loop to stop; nothing is interrupted where it stands.

    rclpy's own handlers shut the context down from the signal, under the
    executor's feet: a callback in the middle of a publish then raised
    ``RCLError``, and a second Ctrl-C (``ros2 launch`` sends one to the whole
    process group, a user often a second one) landed inside ``destroy_node``.
    Here a signal only sets a flag; the loop checks it at least every
    :data:`STOP_CHECK_S` and between callbacks, and the teardown runs with
    both signals ignored.
    """

    def __init__(self, with_parent: bool = False):
        self.requested = False
        self._parent = os.getppid() if with_parent else None
        self._previous = {number: signal.signal(number, self._on_signal) for number in _STOP_SIGNALS}

    def _on_signal(self, number, frame) -> None:
        self.requested = True

    def orphaned(self) -> bool:
        """With ``with_parent``: whether the process that started this one has ended (this one was re-parented)."""
        return self._parent is not None and os.getppid() != self._parent

    def ignore(self) -> None:
        """From here on (the teardown) both signals are ignored."""
        for number in _STOP_SIGNALS:
            signal.signal(number, signal.SIG_IGN)

    def restore(self) -> None:
        """Put the handlers back that were there before (for callers in the same process).

        Not after a stop by signal: the process is ending, and a further
        signal must not turn into a KeyboardInterrupt on the way out (Python
        then ends itself by SIGINT, status −2).
        """
        if self.requested:
            return
        for number, handler in self._previous.items():
            signal.signal(number, handler)


def node_main(node_class, managed_class, args=None) -> int:
    """A node's console script (``ros2 run pmv_ros NAME [--managed]``): ``--managed`` among its own arguments
    makes it its managed (lifecycle) class (:mod:`pmv_ros.nodes.managed`); then :func:`run_node`."""
    factory = managed_class if managed_requested(args) else node_class
    return run_node(factory, node_class.NODE_NAME, args)


def _own_flag(args, flag: str) -> bool:
    """Whether ``flag`` is among the node's own arguments (those before ``--ros-args``)."""
    argv = list(sys.argv[1:] if args is None else args)
    if "--ros-args" in argv:
        argv = argv[:argv.index("--ros-args")]
    return flag in argv


def run_node(factory, name: str, args=None) -> int:
    """Create the node with ``factory()`` and spin it until SIGINT, SIGTERM or shutdown; returns the exit status.

    A stop by signal is status 0 with no traceback, also mid-publish and with
    a second signal during the teardown. A bad command line or params file
    (rclpy refuses to initialise) and an invalid parameter value end in one
    line on stderr naming the problem and status 1. A managed node's refusal of
    a transition its state does not have is logged as a warning and the node
    goes on (:mod:`pmv_ros.nodes.managed`).
    """
    try:  # a misspelled key in the node's own params-file section: refused like a bad value
        check_params_files(sys.argv if args is None else args, name)
    except ParameterError as error:
        print(f"{name}: invalid parameter: {error}", file=sys.stderr)
        return 1
    except ValueError as error:  # the params file itself: not a regular file, not YAML, a YAML bomb
        print(f"{name}: cannot start: {error}", file=sys.stderr)
        return 1
    stop = StopRequest(with_parent=_own_flag(args, STOP_WITH_PARENT_FLAG))
    try:
        try:
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        except (rclpy_implementation.RCLError, rclpy_implementation.UnknownROSArgsError) as error:
            print(f"{name}: cannot start: {_one_line(error)}", file=sys.stderr)
            return USAGE_STATUS
        hold_single_threaded_blas()  # for the life of the process
        return _spin(factory, name, stop)
    finally:
        stop.restore()


def _one_line(error: Exception) -> str:
    """rcl's reason for refusing a command line, on one line (rcl appends where in its sources it failed)."""
    text = " ".join(str(error).split())
    if isinstance(error, rclpy_implementation.UnknownROSArgsError):
        return f"unknown ROS arguments after --ros-args: {text}"
    return text.split(", at /")[0]


def _refused_transition(error: Exception) -> bool:
    """Whether ``error`` is rclpy's lifecycle state machine refusing a transition the current state does not have
    (rclpy 7.1 raises it out of the change_state service instead of answering ``success = false``)."""
    return "lifecycle state machine transition" in str(error)


def _spin(factory, name: str, stop: StopRequest) -> int:
    node = executor = None
    status = 0
    try:
        with warnings.catch_warnings(record=True) as caught:
            try:
                node = factory()
            except (rclpy_implementation.RCLError, NameValidationException) as error:
                # rcl refuses the node's name, namespace or a remapped topic (too long, malformed) only when the
                # node or the entity is made: a usage error of the command line, not a fault of the node. rclpy's
                # warnings about the half-made node it then tears down would only bury the one line.
                print(f"{name}: cannot start: {_one_line(error)}", file=sys.stderr)
                return USAGE_STATUS
        for warning in caught:  # a node that was made: its construction's warnings as they would have been
            warnings.showwarning(warning.message, warning.category, warning.filename, warning.lineno)
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while not stop.requested and rclpy.ok():
            if stop.orphaned():
                node.get_logger().warning("the process that started this node is gone (--stop-with-parent): stopping")
                break
            try:
                executor.spin_once(timeout_sec=STOP_CHECK_S)
            except rclpy_implementation.RCLError as error:
                if not _refused_transition(error):
                    raise
                node.get_logger().warning(f"a change_state request refused, unanswered: {error} (rclpy answers "
                                          "none for a transition the current state does not have)")
    except ParameterError as error:
        print(f"{name}: invalid parameter: {error}", file=sys.stderr)
        status = 1
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        stop.ignore()
        if executor is not None:
            executor.shutdown(timeout_sec=1.0)
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return status
