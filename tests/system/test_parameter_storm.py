"""A parameter storm (issue 29): ``set_parameters`` at up to 1,000 requests a second on every node, every one bad.

The three nodes run as their console scripts on the wall clock, on a domain of their own. For 3 s this test
process sends each node ``set_parameters`` requests as fast as it can up to 1,000 a second per node, without
waiting for the answers: a value of the wrong type, one out of range, a read-only name (``input.max_rate_hz``)
and a name the node does not have, in turn. Measured:

* every answer is a refusal with a reason; each node's /diagnostics counts ``rejected_parameter_updates`` —
  at least every answered request, at most every one sent (a request the node's service queue dropped is
  never answered nor counted);
* the storm is said once: at most three log lines per node about refused parameters;
* nothing is lost: the sensor published every sample of its 10 Hz grid through the storm, the monitor
  aligned ≥ 99 % of them but those the star tracker's own sky left without truth (a frame it reported
  without attitude within max_truth_gap_s: ≈ 3 % of frames fail recognition in a field of 8 stars, more
  where stars are few, and there frame after frame; at 1 Hz two failed frames in a row leave 3 s without
  truth); no node's memory grows by 20 MB or more; every parameter kept its value.

And a storm of good requests: ``use_sim_time`` flipped at ≈ 100 Hz on the two nodes that follow the sensor's
/clock, for 3 s (60 s with ``--run-long``). rclpy makes and destroys a node's /clock subscription at every flip,
beside a live /clock publisher: the endpoint churn under which Fast DDS 2.14 crashed a flapping managed node
(README "Managed nodes"). Every node runs on, the chain gives residuals again once ``use_sim_time`` is back on,
and the /clock guard holds on the subscription the last flip made (a negative /clock is counted, not fatal).
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from neighbour import (WALL_CLOCK_PARAMS, Neighbour, monitor_status, node_statuses, output_of, proc_status,
                       running_nodes, running_stack)
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.parameter import Parameter
from rclpy.parameter import parameter_value_to_python
from rosgraph_msgs.msg import Clock

import pmv_msgs_shim as shim

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

PARAMS = WALL_CLOCK_PARAMS
#: Per node: (a parameter it has, a value of the wrong type, one out of range); every node has input.max_rate_hz
#: (read-only) and none has "no_such.parameter".
STORM = {"sensor_node": ("sensor.rate_hz", "fast", 1e9), "star_tracker_node": ("frame_period_s", "fast", 1e9),
         "error_monitor_node": ("statistics_rate_hz", "often", 1e9)}
STORM_S, TARGET_HZ = 3.0, 1000.0
#: The use_sim_time flips: per node and second, and for how long (s): default, and with --run-long.
FLIP_HZ, FLIP_S, FLIP_LONG_S = 100.0, 3.0, 60.0


def _requests(node: str) -> list:
    name, wrong_type, out_of_range = STORM[node]
    return [SetParameters.Request(parameters=[Parameter(n, value=v).to_parameter_msg()]) for n, v in (
        (name, wrong_type), (name, out_of_range), ("input.max_rate_hz", 100.0), ("no_such.parameter", 1.0))]


@pytest.fixture
def stack(tmp_path):
    with running_nodes(tmp_path, PARAMS) as processes:
        yield processes


def test_a_parameter_storm_is_refused_counted_and_said_once(stack, tmp_path):
    neighbour = Neighbour()
    try:
        node = neighbour.node
        attitude = neighbour.got["attitude"]
        clients = {name: node.create_client(SetParameters, f"/{name}/set_parameters") for name in STORM}
        getters = {name: node.create_client(GetParameters, f"/{name}/get_parameters") for name in STORM}
        neighbour.wait_until(lambda: all(c.service_is_ready() for c in [*clients.values(), *getters.values()]),
                             90.0, "the parameter services of the three nodes")
        neighbour.wait_until(lambda: len(neighbour.got["residual"]) > 10, 90.0, "residuals from the chain")

        def value(name: str, parameter: str):
            future = getters[name].call_async(GetParameters.Request(names=[parameter]))
            neighbour.wait_until(future.done, 20.0, f"{parameter} of {name}")
            return parameter_value_to_python(future.result().values[0])

        kept = {name: value(name, STORM[name][0]) for name in STORM}
        rss_before = {name: proc_status(process.pid)["rss_mb"] for name, process in stack.items()}
        storm_from = time.time()

        requests = {name: _requests(name) for name in STORM}
        futures = {name: [] for name in STORM}
        began, k = time.monotonic(), 0
        while time.monotonic() - began < STORM_S:
            for name, client in clients.items():
                futures[name].append(client.call_async(requests[name][k % 4]))
            k += 1
            if k % 20 == 0:
                neighbour.executor.spin_once(timeout_sec=0.0)
            pause = began + k / TARGET_HZ - time.monotonic()
            if pause > 0:
                time.sleep(pause)
        storm_s, storm_to = time.monotonic() - began, time.time()
        neighbour.spin(1.0)  # the answers and the samples on their way
        window = sorted(t for t in (shim.time_from_msg(m.header.stamp) for m in attitude)
                        if storm_from <= t <= storm_to)
        neighbour.wait_for_reports("sensor_node: horizon", "star_tracker_node", "error_monitor_node")
        deadline = time.monotonic() + 30.0  # the residual of the storm's last sample comes with its truth
        while max(shim.time_from_msg(m.header.stamp) for m in neighbour.got["residual"]) < window[-1]:
            assert time.monotonic() < deadline, "no residual for the last sample of the storm within 30 s"
            neighbour.spin(0.2)
        rss_after = {name: proc_status(process.pid)["rss_mb"] for name, process in stack.items()}

        for name, process in stack.items():
            assert process.poll() is None, f"{name} died: {output_of(tmp_path, name)[-2000:]}"
        figures = {}
        for name in STORM:
            answered = [f.result() for f in futures[name] if f.done()]
            results = [r for response in answered for r in response.results]
            status = (node_statuses(neighbour.got["diagnostics"], "sensor_node: horizon") if name == "sensor_node"
                      else node_statuses(neighbour.got["diagnostics"], name))[-1]
            counted = int(dict(status.values).get("rejected_parameter_updates", 0))
            lines = [line for line in output_of(tmp_path, name).splitlines() if "refused a parameter update" in line]
            figures[name] = dict(sent=len(futures[name]), answered=len(answered), counted=counted, lines=lines,
                                 rss=(round(rss_before[name], 1), round(rss_after[name], 1)))
        stamps = np.array(window)
        took = neighbour.alignment(window)
        monitor = {k: v for k, v in dict(monitor_status(neighbour.got["diagnostics"]).values).items()
                   if k.startswith(("skipped_", "truth_lost_"))}
        rate = {name: round(len(futures[name]) / storm_s) for name in STORM}
        shown = {name: {**f, "lines": len(f["lines"])} for name, f in figures.items()}
        print(f"parameter storm, {storm_s:.1f} s at {rate} requests/s: {shown}; {stamps.size} samples in the storm, "
              f"largest gap {np.diff(stamps).max():.3f} s, {took}; the monitor's skips {monitor}")
        for name in STORM:
            answered = [f.result() for f in futures[name] if f.done()]
            results = [r for response in answered for r in response.results]
            counted, lines = figures[name]["counted"], figures[name]["lines"]
            assert results and not any(r.successful for r in results), name
            assert all(r.reason for r in results), name
            assert len(answered) <= counted <= len(futures[name]), (name, figures[name])
            assert 1 <= len(lines) <= 3, (name, lines)
            assert rss_after[name] - rss_before[name] < 20.0, (name, figures[name])
            assert value(name, STORM[name][0]) == kept[name], name
        assert min(rate.values()) >= 0.3 * TARGET_HZ, rate  # as close to 1,000/s as this process gets on 2 cores
        assert stamps.size >= 20 and np.allclose(np.diff(stamps), 0.1, atol=1e-6), np.diff(stamps).max()
        assert took.share >= 0.99, (str(took), took.other, monitor)
    finally:
        neighbour.close()


@pytest.mark.long
def test_use_sim_time_flipped_beside_a_clock_publisher_stops_no_node(tmp_path, run_long):
    flip_s = FLIP_LONG_S if run_long else FLIP_S
    with running_stack(tmp_path) as stack:
        neighbour = Neighbour()
        try:
            neighbour.wait_for_stack(residuals=5)
            followers = ("star_tracker_node", "error_monitor_node")
            clients = {name: neighbour.node.create_client(SetParameters, f"/{name}/set_parameters")
                       for name in followers}
            neighbour.wait_until(lambda: all(c.service_is_ready() for c in clients.values()), 30.0,
                                 "the parameter services of the two nodes")
            flips = {name: [] for name in followers}
            began, k = time.monotonic(), 0
            while time.monotonic() - began < flip_s:
                request = SetParameters.Request(parameters=[Parameter("use_sim_time", value=k % 2 == 1)
                                                            .to_parameter_msg()])  # false first, true last
                for name, client in clients.items():
                    flips[name].append(client.call_async(request))
                k += 1
                while time.monotonic() < began + k / FLIP_HZ:
                    neighbour.executor.spin_once(timeout_sec=0.002)
            if k % 2:  # an odd count ended on false: back on the sensor's /clock
                for name, client in clients.items():
                    flips[name].append(client.call_async(SetParameters.Request(parameters=[
                        Parameter("use_sim_time", value=True).to_parameter_msg()])))
            # The last request to each node is answered (a request queue of keep-last 10 drops the oldest when a
            # busy node falls behind — and so may the neighbour's reply queue — never the newest); every other answer
            # that comes has come before it.
            if not neighbour.wait_for(lambda: all(futures[-1].done() for futures in flips.values()), 30.0):
                raise AssertionError(f"no answer to the last use_sim_time request within 30 s; answered "
                                     f"{ {name: sum(f.done() for f in futures) for name, futures in flips.items()} } "
                                     f"of { {name: len(futures) for name, futures in flips.items()} }, alive "
                                     f"{ {name: process.poll() is None for name, process in stack.items()} }")
            residuals = len(neighbour.got["residual"])
            neighbour.wait_until(lambda: len(neighbour.got["residual"]) > residuals + 10, 60.0,
                                 "residuals after the flips")
            negative = Clock()
            negative.clock.sec = -1

            def newest_values() -> tuple[dict, dict]:  # the two followers' newest /diagnostics values
                monitor, tracker = (monitor_status(neighbour.got["diagnostics"]),
                                    node_statuses(neighbour.got["diagnostics"], "star_tracker_node"))
                return (dict(monitor.values) if monitor else {}), (dict(tracker[-1].values) if tracker else {})

            def counted_or_dead() -> bool:
                # The guard on the last /clock subscription: a negative /clock every 0.1 s until both nodes report
                # one refused (their /clock queue keeps one message: a real one can replace a single negative).
                neighbour.pub["clock"].publish(negative)
                neighbour.spin(0.1)
                return (any(process.poll() is not None for process in stack.values())
                        or all(int(c.get("rejected_clock_negative", 0)) >= 1 for c in newest_values()))

            neighbour.wait_until(counted_or_dead, 30.0, "a negative /clock counted on /diagnostics by both followers")
            if all(process.poll() is None for process in stack.values()):
                neighbour.wait_for_reports("error_monitor_node", "star_tracker_node")  # and they run on
            for name, process in stack.items():
                assert process.poll() is None, f"{name} died: {output_of(tmp_path, name)[-2000:]}"
            answers = {name: [r for f in futures if f.done() for r in f.result().results]
                       for name, futures in flips.items()}
            rate = {name: round(len(futures) / flip_s) for name, futures in flips.items()}
            monitor, tracker = newest_values()
            print(f"use_sim_time flipped {flip_s:g} s at {rate} requests/s beside /clock: "
                  f"{ {name: sum(r.successful for r in a) for name, a in answers.items()} } made of "
                  f"{ {name: len(futures) for name, futures in flips.items()} } sent; rejected "
                  f"negative /clock after: monitor {monitor.get('rejected_clock_negative')}, star tracker "
                  f"{tracker.get('rejected_clock_negative')}")
            assert all(r.successful for a in answers.values() for r in a), answers
            assert min(rate.values()) >= 0.5 * FLIP_HZ, rate
            for counters in (monitor, tracker):
                assert int(counters.get("rejected_clock_negative", 0)) >= 1, counters
        finally:
            neighbour.close()
