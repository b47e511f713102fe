"""Subscriptions of a neighbour whose QoS cannot match a node's publisher: counted, not a log line each.

rclpy's default handler of the incompatible-QoS event logs a warning per event; a neighbour that keeps making
mismatched subscriptions (here: transient-local ones on ``/diagnostics``, which every node publishes volatile)
flooded every node's log without bound. The node's own handler counts them (``incompatible_qos`` in its
/diagnostics status) and its log says the first at once, then at most one line a minute with the count since.
"""

from __future__ import annotations

import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from neighbour import WALL_CLOCK_PARAMS, Neighbour, node_statuses, output_of, running_nodes
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.qos import DurabilityPolicy, QoSProfile

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

#: Mismatched subscriptions the neighbour makes: each is one incompatible-QoS event in the node.
MISMATCHED = 40


def _counted(messages) -> int:
    statuses = node_statuses(messages, "error_monitor_node")
    return max((int(dict(s.values).get("incompatible_qos", 0)) for s in statuses), default=0)


def test_incompatible_subscriptions_are_counted_not_logged_each(tmp_path):
    with running_nodes(tmp_path, WALL_CLOCK_PARAMS, nodes=("error_monitor_node",)) as processes:
        neighbour = Neighbour()
        try:
            neighbour.wait_for_reports("error_monitor_node", count=1, seconds=60.0)
            started = time.monotonic()
            latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
            quiet = SubscriptionEventCallbacks(use_default_callbacks=False)
            for _ in range(MISMATCHED):
                neighbour.node.create_subscription(DiagnosticArray, "/diagnostics", lambda message: None, latched,
                                                   event_callbacks=quiet)
            neighbour.wait_until(lambda: _counted(neighbour.got["diagnostics"]) >= MISMATCHED, 30.0,
                                 f"incompatible_qos >= {MISMATCHED} on /diagnostics")
            elapsed_s = time.monotonic() - started
            assert processes["error_monitor_node"].poll() is None
        finally:
            neighbour.close()
    log = output_of(tmp_path, "error_monitor_node")
    said = [line for line in log.splitlines() if "incompatible" in line.lower()]
    assert 1 <= len(said) <= 2, "\n".join(said[:5]) + f"\n… {len(said)} lines"
    assert "/diagnostics" in said[0] and "durability" in said[0], said[0]
    print(f"{MISMATCHED} mismatched subscriptions: counted {_counted(neighbour.got['diagnostics'])}, "
          f"{len(said)} log line(s), {elapsed_s:.1f} s")
