"""One ``main`` for every node executable: start, spin, and fail cleanly on bad configuration."""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.impl.implementation_singleton import rclpy_implementation

from .base import hold_single_threaded_blas
from .params import ParameterError


def run_node(factory, name: str, args=None) -> int:
    """Create the node with ``factory()`` and spin it until shutdown; returns the exit status.

    A bad command line or params file (rclpy refuses to initialise) and an
    invalid parameter value both end in one line on stderr naming the problem
    and exit status 1 — no traceback for a configuration mistake.
    """
    try:
        rclpy.init(args=args)
    except rclpy_implementation.RCLError as error:
        print(f"{name}: cannot start: {error}", file=sys.stderr)
        return 1
    node = None
    hold_single_threaded_blas()  # for the life of the process
    try:
        node = factory()
        rclpy.spin(node)
    except ParameterError as error:
        print(f"{name}: invalid parameter: {error}", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return 0
