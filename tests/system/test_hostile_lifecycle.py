"""The lifecycle services called by a hostile neighbour (issue 29): flapping at 100 Hz, a transition during shutdown.

The three nodes run as ``--managed`` console scripts on a domain of their own. This test process calls their
``change_state`` services from outside, as anyone on the domain can:

* **flapping** — configure, activate, deactivate, cleanup in turn, 100 requests a second to each node for
  3 s, without waiting for the answers. Afterwards every node answers ``get_state`` with one of its primary
  states, is brought to ``unconfigured`` and measured against itself after a warm-up of five clean cycles:
  resident memory (< 15 MB more), threads (no more), and its publishers, subscriptions and services as the
  graph shows them (the same). Then configured and activated once more, the chain runs: residuals come out.
  (The nodes are started once for the module; this test leaves them active for the next.)
* **a transition the state does not have** — no answer (rclpy 7.1), a line in the node's log, and the node
  goes on as it was;
* **a transition during shutdown** — SIGTERM to each node while the neighbour keeps calling ``change_state``
  at 100 Hz: each ends within 5 s with status 0 and no traceback.
"""

from __future__ import annotations

import signal
import subprocess
import time

import pytest
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from neighbour import WALL_CLOCK_PARAMS, Neighbour, output_of, proc_status, running_nodes

from pmv_ros.nodes.managed import PARKED_S

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

NODES = ("error_monitor_node", "star_tracker_node", "sensor_node")
PARAMS = WALL_CLOCK_PARAMS
CYCLE = (Transition.TRANSITION_CONFIGURE, Transition.TRANSITION_ACTIVATE, Transition.TRANSITION_DEACTIVATE,
         Transition.TRANSITION_CLEANUP)
PRIMARY = {"unconfigured", "inactive", "active", "finalized"}
FLAP_HZ, FLAP_S = 100.0, 3.0
STOP_LIMIT_S = 5.0


class Lifecycles:
    """The lifecycle clients of the three nodes, from the neighbour."""

    def __init__(self, neighbour: Neighbour):
        self.neighbour = neighbour
        node = neighbour.node
        self.change = {name: node.create_client(ChangeState, f"/{name}/change_state") for name in NODES}
        self.get = {name: node.create_client(GetState, f"/{name}/get_state") for name in NODES}

    def wait_for_services(self, seconds: float = 90.0) -> None:
        self.neighbour.wait_until(lambda: all(c.service_is_ready() for c in [*self.change.values(),
                                                                             *self.get.values()]),
                                  seconds, "the lifecycle services of the three nodes")

    def call(self, client, request, seconds: float = 20.0):
        future = client.call_async(request)
        self.neighbour.wait_until(future.done, seconds, f"an answer from {client.srv_name}")
        return future.result()

    def state(self, name: str) -> str:
        return self.call(self.get[name], GetState.Request()).current_state.label

    def transition(self, name: str, transition: int) -> bool:
        return self.call(self.change[name], ChangeState.Request(transition=Transition(id=transition))).success

    def to_unconfigured(self, name: str) -> None:
        state = self.state(name)
        if state == "active":
            assert self.transition(name, Transition.TRANSITION_DEACTIVATE), name
            state = "inactive"
        if state == "inactive":
            assert self.transition(name, Transition.TRANSITION_CLEANUP), name
        assert self.state(name) == "unconfigured", name

    def flap(self, seconds: float, hz: float, until=None) -> dict:
        """Requests to every node's change_state at ``hz`` each, cycling CYCLE, answers not awaited; counts."""
        sent = {name: 0 for name in NODES}
        futures = []
        period, began = 1.0 / hz, time.monotonic()
        k = 0
        while time.monotonic() - began < seconds and (until is None or not until()):
            for name in NODES:
                request = ChangeState.Request(transition=Transition(id=CYCLE[k % len(CYCLE)]))
                futures.append(self.change[name].call_async(request))
                sent[name] += 1
            k += 1
            while time.monotonic() < began + k * period:
                self.neighbour.executor.spin_once(timeout_sec=max(0.0, began + k * period - time.monotonic()))
        self.neighbour.spin(1.0)  # the answers on their way
        answered = [f for f in futures if f.done()]
        return {"sent": sent, "answered": len(answered), "succeeded": sum(f.result().success for f in answered),
                "rate_hz": k / (time.monotonic() - began - 1.0)}


def _graph_entities(neighbour: Neighbour, name: str) -> tuple:
    node = neighbour.node
    return (sorted(t for t, _ in node.get_publisher_names_and_types_by_node(name, "/")),
            sorted(t for t, _ in node.get_subscriber_names_and_types_by_node(name, "/")),
            sorted(s for s, _ in node.get_service_names_and_types_by_node(name, "/")))


def _settled_entities(neighbour: Neighbour) -> dict:
    """Each node's entities once the graph of all three has stopped changing for 1 s more than a cleanup keeps
    its endpoints parked (discovery of destroyed ones takes a moment); the three are watched together."""
    last, steady_since = None, time.monotonic()
    deadline = time.monotonic() + 20.0
    while time.monotonic() < deadline:
        now = {name: _graph_entities(neighbour, name) for name in NODES}
        if now != last:
            last, steady_since = now, time.monotonic()
        elif time.monotonic() - steady_since > PARKED_S + 1.0:
            return now
        neighbour.spin(0.1)
    raise AssertionError(f"the graph of the nodes kept changing for 20 s: {last}")


@pytest.fixture(scope="module")
def managed_stack(tmp_path_factory):
    """The three managed nodes, started once for the module (the shutdown test, which ends them, runs last)."""
    tmp_path = tmp_path_factory.mktemp("managed_stack")
    with running_nodes(tmp_path, PARAMS, nodes=NODES, arguments={name: ["--managed"] for name in NODES}) as processes:
        yield processes, tmp_path


def test_flapping_transitions_leave_every_node_defined_and_leak_nothing(managed_stack):
    managed_stack, tmp_path = managed_stack
    neighbour = Neighbour()
    try:
        lifecycles = Lifecycles(neighbour)
        lifecycles.wait_for_services()
        for _ in range(5):  # warm-up: every import and first-time allocation done
            for name in NODES:
                for transition in CYCLE:
                    assert lifecycles.transition(name, transition), (name, transition)
        entities = _settled_entities(neighbour)
        before = {name: (proc_status(managed_stack[name].pid), entities[name]) for name in NODES}

        counts = lifecycles.flap(FLAP_S, FLAP_HZ)

        states = {name: lifecycles.state(name) for name in NODES}
        for name in NODES:
            lifecycles.to_unconfigured(name)
        entities = _settled_entities(neighbour)
        after = {name: (proc_status(managed_stack[name].pid), entities[name]) for name in NODES}
        for name, process in managed_stack.items():
            assert process.poll() is None, f"{name} died: {output_of(tmp_path, name)[-2000:]}"
        print(f"lifecycle flapping at {counts['rate_hz']:.0f} Hz a node for {FLAP_S:g} s: sent {counts['sent']}, "
              f"{counts['answered']} answered, {counts['succeeded']} transitions made; states after {states}; "
              + "; ".join(f"{name}: RSS {before[name][0]['rss_mb']:.1f} → {after[name][0]['rss_mb']:.1f} MB, threads "
                          f"{before[name][0]['threads']} → {after[name][0]['threads']}, entities "
                          f"{sum(map(len, before[name][1]))} → {sum(map(len, after[name][1]))}" for name in NODES))
        assert set(states.values()) <= PRIMARY - {"finalized"}, states
        assert counts["rate_hz"] > 0.8 * FLAP_HZ and counts["succeeded"] > 0, counts
        for name in NODES:
            (status_before, entities_before), (status_after, entities_after) = before[name], after[name]
            assert entities_after == entities_before, (name, entities_before, entities_after)
            assert status_after["threads"] <= status_before["threads"], (name, status_before, status_after)
            assert status_after["rss_mb"] - status_before["rss_mb"] < 15.0, (name, status_before, status_after)

        # Defined, and working: configured and activated once more, the chain aligns samples.
        residuals = len(neighbour.got["residual"])
        for name in NODES:
            assert lifecycles.transition(name, Transition.TRANSITION_CONFIGURE), name
            assert lifecycles.transition(name, Transition.TRANSITION_ACTIVATE), name
        neighbour.wait_until(lambda: len(neighbour.got["residual"]) > residuals + 10, 60.0,
                             "residuals after the flapping")
    finally:
        neighbour.close()


def test_a_transition_the_state_does_not_have_is_refused_unanswered_and_the_node_keeps_serving(managed_stack):
    """rclpy 7.1 raises its refusal out of the change_state service (no answer, where earlier versions of this
    package answered ``success = false``): the node logs it, keeps its state and goes on serving."""
    managed_stack, tmp_path = managed_stack
    neighbour = Neighbour()
    try:
        lifecycles = Lifecycles(neighbour)
        lifecycles.wait_for_services()
        state = lifecycles.state("sensor_node")
        refused = Transition.TRANSITION_CONFIGURE if state != "unconfigured" else Transition.TRANSITION_ACTIVATE
        future = lifecycles.change["sensor_node"].call_async(ChangeState.Request(transition=Transition(id=refused)))
        neighbour.wait_until(lambda: "change_state request refused" in output_of(tmp_path, "sensor_node"), 20.0,
                             "the refusal in the sensor's log")
        neighbour.spin(1.0)
        assert not future.done() and managed_stack["sensor_node"].poll() is None
        assert lifecycles.state("sensor_node") == state
        future.cancel()
    finally:
        neighbour.close()


def test_a_transition_during_shutdown_ends_every_node_cleanly(managed_stack):
    """Runs last in the module: it ends the module's nodes."""
    managed_stack, tmp_path = managed_stack
    neighbour = Neighbour()
    try:
        lifecycles = Lifecycles(neighbour)
        lifecycles.wait_for_services()
        for name in NODES:
            if lifecycles.state(name) == "unconfigured":
                assert lifecycles.transition(name, Transition.TRANSITION_CONFIGURE), name
            if lifecycles.state(name) == "inactive":
                assert lifecycles.transition(name, Transition.TRANSITION_ACTIVATE), name
        residuals = len(neighbour.got["residual"])
        neighbour.wait_until(lambda: len(neighbour.got["residual"]) > residuals + 5, 60.0,
                             "residuals from the active chain")
        lifecycles.flap(0.3, FLAP_HZ)  # transitions in flight when the signal comes
        sent = time.monotonic()
        for process in managed_stack.values():
            process.send_signal(signal.SIGTERM)
        exited = {}  # name → seconds from the signal to the exit, as seen between two requests

        def all_exited() -> bool:
            for name, process in managed_stack.items():
                if name not in exited and process.poll() is not None:
                    exited[name] = time.monotonic() - sent
            return len(exited) == len(managed_stack)

        lifecycles.flap(STOP_LIMIT_S, FLAP_HZ, until=all_exited)
        ended = {}
        for name, process in managed_stack.items():
            try:
                ended[name] = (process.wait(timeout=max(0.1, sent + STOP_LIMIT_S - time.monotonic())),
                               exited.get(name, time.monotonic() - sent))
            except subprocess.TimeoutExpired:
                ended[name] = (None, None)
        print(f"SIGTERM during transitions at {FLAP_HZ:g} Hz: {ended}")
        for name, (status, _) in ended.items():
            text = output_of(tmp_path, name)
            assert status == 0, f"{name}: status {status}\n{text[-2000:]}"
            assert ended[name][1] < STOP_LIMIT_S, (name, ended[name])
            assert "Traceback" not in text and "RCLError" not in text, f"{name}:\n{text[-2000:]}"
    finally:
        neighbour.close()
