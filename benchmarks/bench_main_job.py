"""The main job against the rclpy floor of its own messages, in one process and one run.

(a) The main job: ``pmv simulate``'s pipeline (:class:`pmv_ros.nodes.pipeline.Pipeline`, lean nodes, the
report collector) on the Kondor preset at 10 Hz, stepped for ``--orbits`` (default 0.2) of an orbit.

(b) The floor: bare rclpy publishing and taking exactly the messages the main job published and took, tick by
tick — the same topics and message types (each message a copy of one the main job sent, so the same sizes), from
nodes of the same names holding the same publishers and the same subscriptions (the same QoS, in the same order,
each taking what is queued in one wake-up where the main job's does), on the same executor drained the same way
after every tick (:func:`pmv_ros.nodes.pipeline.drain`: by takes, the floors having no timers never wait; the main
job waits at the ticks its timers fall due) — and no computation: every callback only counts, and a
tick publishes its messages at once. What the main job does
besides (the sensor's physics, the star tracker, the monitor, writing the messages, its timers and wake-up
guards, the messages one callback publishes for the next node) is the ratio's excess over 1.

Beside them, each round also drains the floor by rclpy's own waits (every look a wait, the wait set built anew):
the floor as it was measured before the drain by takes, printed with its ratio before the last line.

The recording round also times what the main job spends inside its three runtimes (every public method of each
node's runtime: the sensor's physics, the star tracker, the monitor's alignment, statistics and health — the graph
queries their health makes through the node included, a few µs a tick). The main job publishes and takes the
floor's messages and does that computation too, so floor + runtimes is a bound no cheaper glue takes it below
(an estimate: one cold round against the floor's median); it is printed as a ratio to the floor before the last
line. (Against the floor drained by rclpy's waits it is no bound: the main job drains by takes.)

(c) The main job without rclpy's internals (:mod:`pmv_ros.nodes.rclpy_internals` switched to its public
fallbacks: the drain by rclpy's waits, one message per subscription a wait, the clock read through
``Clock.now()``): what the fenced module is still worth, printed as its ratio to (a) before the last line.
``--internals-only`` runs (a) and (c) alone, alternating.

The tick-by-tick schedule of (b) is recorded from (a)'s first round (which messages went out at which tick, and
one copy of each topic's message); the rounds then alternate, (a) (b) (a) (b) …, and each figure is the median of
its rounds; the ratio of every round is printed. The last line is the ratio of the medians.

    .venv/bin/python benchmarks/bench_main_job.py [--orbits 0.2] [--rounds 3] [--internals-only]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from collections import Counter
from pathlib import Path

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_bench_log_"))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"

import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.publisher import Publisher  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402

from pmv_ros.nodes import rclpy_internals  # noqa: E402
from pmv_ros.nodes.base import QOS_DEPTH, PmvNode  # noqa: E402
from pmv_ros.nodes.pipeline import Pipeline, TakingQueued, drain  # noqa: E402
from pmv_ros.nodes.rclpy_internals import taking_queued  # noqa: E402

KONDOR = Path(__file__).resolve().parents[1] / "config" / "kondor.yaml"


class Recorder:
    """While installed: every publish in the process, by tick — (node, topic) and one copy of each topic's message."""

    def __init__(self):
        self.tick, self.schedule, self.messages, self.takes = 0, [], {}, []
        self._original = Publisher.publish

    def __enter__(self):
        original, recorder = self._original, self

        def recorded(publisher, message):
            topic = publisher.topic_name
            recorder.schedule[-1].append(topic)
            if topic not in recorder.messages:
                recorder.messages[topic] = (type(message), serialize_message(message))
            return original(publisher, message)

        Publisher.publish = recorded
        return self

    def __exit__(self, *exc):
        Publisher.publish = self._original


class RuntimeTimes:
    """While installed on nodes (a pipeline's, or some of them): wall time spent inside their runtimes (every
    public method of each node's runtime, outermost calls only), per node name — the computation the main job
    does besides ROS. ``benchmarks/bench_closed_loop.py`` uses it too."""

    def __init__(self, nodes):
        self.seconds = Counter()
        self._depth = [0]
        for node in nodes:
            runtime = getattr(node, "runtime", None)
            for name in dir(type(runtime)) if runtime is not None else ():
                if not name.startswith("_") and callable(getattr(type(runtime), name, None)):
                    setattr(runtime, name, self._timed(getattr(runtime, name), node.get_name()))

    def _timed(self, method, owner: str):
        depth, seconds, clock = self._depth, self.seconds, time.perf_counter

        def timed(*arguments, **keywords):
            if depth[0]:
                return method(*arguments, **keywords)
            depth[0] = 1
            started = clock()
            try:
                return method(*arguments, **keywords)
            finally:
                seconds[owner] += clock() - started
                depth[0] = 0

        return timed


def graph_of(pipeline: Pipeline) -> list[dict]:
    """Per node of the pipeline: its name, its publishers' (topic, type, QoS), its subscriptions' (topic, type,
    QoS, whether it takes what is queued in one wake-up: :class:`TakingQueued`) in order."""
    return [{"name": node.get_name(),
             "publishers": [(p.topic_name, p.msg_type, p.qos_profile) for p in node.publishers],
             "subscriptions": [(s.topic_name, s.msg_type, s.qos_profile, isinstance(s.callback, TakingQueued))
                               for s in node.subscriptions]}
            for node in pipeline.nodes]


def main_job(ticks: int, record: bool = False, internals: bool = True) -> dict:
    """Wall time of ``ticks`` pipeline steps on the Kondor preset (construction not counted); ``internals``
    False: with :mod:`pmv_ros.nodes.rclpy_internals`' public fallbacks."""
    before = rclpy_internals.internals_in_use()
    rclpy_internals.use_internals(internals)
    try:
        return _main_job(ticks, record)
    finally:
        rclpy_internals.use_internals(before)


def _main_job(ticks: int, record: bool) -> dict:
    with Pipeline(KONDOR) as pipeline:
        graph = graph_of(pipeline)
        taken = Counter()
        recorder = Recorder() if record else None
        runtimes = RuntimeTimes(pipeline.nodes) if record else None
        for node in pipeline.nodes:  # count what each subscription takes (and, recording, which node, which tick)
            for subscription in node.subscriptions:
                holder = subscription.callback if isinstance(subscription.callback, TakingQueued) else subscription
                holder.callback = _counting(holder.callback, taken, subscription.topic_name, recorder, node.get_name())
        started, cpu = time.perf_counter(), time.process_time()
        if recorder is None:
            pipeline.step(ticks)
        else:
            with recorder:
                for _ in range(ticks):
                    recorder.schedule.append([])
                    recorder.takes.append(Counter())
                    pipeline.step()
        wall, cpu = time.perf_counter() - started, time.process_time() - cpu
        used = pipeline.monitor.monitor.counters["used"]
    result = {"wall_s": wall, "cpu_s": cpu, "ticks": ticks, "taken": dict(taken), "used": used, "graph": graph}
    if recorder is not None:
        owner = {topic: spec["name"] for spec in graph for topic, _, _ in spec["publishers"]}
        result.update(schedule=recorder.schedule, messages=recorder.messages, takes=recorder.takes, owner=owner,
                      runtime_s=dict(runtimes.seconds))
    return result


def _counting(callback, counter: Counter, topic: str, recorder=None, node_name: str = ""):
    import inspect

    def counted(*arguments):
        counter[topic] += 1
        if recorder is not None and recorder.takes:
            recorder.takes[-1][node_name] += 1
        return callback(*arguments)

    counted.__signature__ = inspect.signature(callback)
    return counted


def floor(recorded: dict, by_takes: bool = True) -> dict:
    """Wall time of the recorded ticks' messages through bare rclpy (see the module docstring); ``by_takes``
    False: drained by rclpy's own waits (the floor as it was before the drain by takes)."""
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    taken = Counter()
    publishers, nodes = {}, []
    for spec in recorded["graph"]:
        node = PmvNode(spec["name"], lean=True, context=context)
        # the main job's nodes are lean: rclpy's /parameter_events publisher is theirs too (made by the node)
        for topic, kind, qos in spec["publishers"]:
            if topic not in ("/parameter_events",):
                publishers[topic] = node.create_publisher(kind, topic, qos, **node.quiet_options("Publisher"))
        for topic, kind, qos, queued in spec["subscriptions"]:
            _subscribe(node, kind, topic, lambda message, topic=topic: taken.update((topic,)), qos, queued)
        nodes.append(node)
        executor.add_node(node)
    messages = {topic: deserialize_message(data, kind) for topic, (kind, data) in recorded["messages"].items()}
    schedule = [[(publishers[topic], messages[topic]) for topic in tick] for tick in recorded["schedule"]]
    drain(executor, by_takes=by_takes)
    started, cpu = time.perf_counter(), time.process_time()
    for tick in schedule:
        for publisher, message in tick:
            publisher.publish(message)
        drain(executor, by_takes=by_takes)
    return _closed(executor, nodes, context, time.perf_counter() - started, time.process_time() - cpu, taken)


def _subscribe(node, kind, topic: str, callback, qos, queued: bool) -> None:
    """A floor's subscription as the main job's: taking what is queued in one wake-up where that one does."""
    if queued:
        taking_queued(lambda taker: node.create_subscription(kind, topic, taker, qos,
                                                             **node.quiet_options("Subscription")), callback, QOS_DEPTH)
    else:
        node.create_subscription(kind, topic, callback, qos, **node.quiet_options("Subscription"))


def _closed(executor, nodes, context, wall_s: float, cpu_s: float, taken: Counter) -> dict:
    """Tear a floor's graph down; its figures."""
    executor.shutdown()
    for node in nodes:
        node.destroy_node()
    rclpy.shutdown(context=context)
    return {"wall_s": wall_s, "cpu_s": cpu_s, "taken": dict(taken)}


def graph_floor(recorded: dict) -> dict:
    """The recorded messages along the main job's own chain, with no computation: each node publishes its tick's
    messages (copies) from the callback that takes its last input of that tick, as an unbatched node would; the
    sensor's at the tick. The same nodes, topics, types, subscriptions and drain — not the timers, the time
    sources or the hand-overs. A diagnosis beside the floor: what the chain itself costs."""
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    taken, got, nodes, publishers = Counter(), Counter(), [], {}
    state = {"tick": 0}
    messages = {topic: deserialize_message(data, kind) for topic, (kind, data) in recorded["messages"].items()}
    owner = recorded["owner"]
    by_node = [{} for _ in recorded["schedule"]]  # tick → node → [(topic)…]
    for tick, topics in enumerate(recorded["schedule"]):
        for topic in topics:
            by_node[tick].setdefault(owner[topic], []).append(topic)

    def publish(name: str) -> None:
        for topic in by_node[state["tick"]].get(name, ()):
            publishers[topic].publish(messages[topic])

    for spec in recorded["graph"]:
        name = spec["name"]
        node = PmvNode(name, lean=True, context=context)
        for topic, kind, qos in spec["publishers"]:
            if topic != "/parameter_events":
                publishers[topic] = node.create_publisher(kind, topic, qos, **node.quiet_options("Publisher"))

        def on_message(message, topic=None, name=name):
            taken[topic] += 1
            got[name] += 1
            if got[name] == recorded["takes"][state["tick"]][name]:
                publish(name)

        for topic, kind, qos, queued in spec["subscriptions"]:
            _subscribe(node, kind, topic, lambda message, topic=topic, callback=on_message: callback(message, topic),
                       qos, queued)
        nodes.append(node)
        executor.add_node(node)
    drain(executor)
    started, cpu = time.perf_counter(), time.process_time()
    for tick in range(len(recorded["schedule"])):
        state["tick"] = tick
        got.clear()
        for name in by_node[tick]:
            if not recorded["takes"][tick][name]:  # the sensor (and a node that took nothing this tick)
                publish(name)
        drain(executor)
    return _closed(executor, nodes, context, time.perf_counter() - started, time.process_time() - cpu, taken)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orbits", type=float, default=0.2, help="orbits of the main job per round (default 0.2)")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds of each (default 3)")
    parser.add_argument("--internals-only", action="store_true",
                        help="only the main job with and without rclpy's internals, alternating")
    args = parser.parse_args()
    with Pipeline(KONDOR) as probe:
        ticks = round(args.orbits * probe.sensor.orbit.period_s * probe.sensor.get_parameter("sensor.rate_hz").value)
    print(f"load average at the start: {os.getloadavg()[0]:.2f} (2-core machines vary 2–3× hour to hour: "
          f"only the ratio of one run means anything)")
    if args.internals_only:
        compare_internals(ticks, args.rounds)
        return
    recorded = main_job(ticks, record=True)
    published = Counter(topic for tick in recorded["schedule"] for topic in tick)
    print(f"main job: {ticks} ticks; per tick it publishes "
          + ", ".join(f"{topic} {count / ticks:.2f}" for topic, count in sorted(published.items()))
          + "; takes "
          + ", ".join(f"{topic} {count / ticks:.2f}" for topic, count in sorted(recorded["taken"].items())))
    jobs, floors, job_cpu, floor_cpu, chains, waited, public = [], [], [], [], [], [], []
    for round_number in range(1, args.rounds + 1):
        job = main_job(ticks)
        unfenced = main_job(ticks, internals=False)
        _same_work(job, unfenced)
        public.append(unfenced["wall_s"])
        base = floor(recorded)
        chain = graph_floor(recorded)
        by_waits = floor(recorded, by_takes=False)
        for name, other in (("floor", base), ("graph floor", chain), ("floor by waits", by_waits)):
            if other["taken"] != recorded["taken"]:
                raise RuntimeError(f"the {name} took {other['taken']}, the main job {recorded['taken']}")
        chains.append(chain["wall_s"])
        waited.append(by_waits["wall_s"])
        jobs.append(job["wall_s"])
        floors.append(base["wall_s"])
        job_cpu.append(job["cpu_s"])
        floor_cpu.append(base["cpu_s"])
        print(f"round {round_number}: main job {job['wall_s']:.2f} s ({job['wall_s'] / ticks * 1e6:.0f} µs/tick), "
              f"floor {base['wall_s']:.2f} s ({base['wall_s'] / ticks * 1e6:.0f} µs/tick), "
              f"ratio {job['wall_s'] / base['wall_s']:.2f}x; by CPU time {job['cpu_s'] / base['cpu_s']:.2f}x; "
              f"graph floor {chain['wall_s'] / ticks * 1e6:.0f} µs/tick, floor by rclpy's waits "
              f"{by_waits['wall_s'] / ticks * 1e6:.0f} µs/tick; without rclpy's internals "
              f"{unfenced['wall_s'] / ticks * 1e6:.0f} µs/tick (load {os.getloadavg()[0]:.2f})")
    job_s, floor_s = statistics.median(jobs), statistics.median(floors)
    print(f"medians: main job {job_s / ticks * 1e6:.0f} µs/tick, floor {floor_s / ticks * 1e6:.0f} µs/tick; "
          f"by the process's CPU time {statistics.median(job_cpu) / statistics.median(floor_cpu):.2f}x (a busy "
          f"neighbour stretches wall time more than CPU time); load average at the end: {os.getloadavg()[0]:.2f}")
    chain_s = statistics.median(chains)
    print(f"graph floor (the same messages along the main job's own chain of nodes, no computation): "
          f"{chain_s / ticks * 1e6:.0f} µs/tick, {chain_s / floor_s:.2f}x the floor; main job / graph floor "
          f"{job_s / chain_s:.2f}x")
    waited_s = statistics.median(waited)
    print(f"floor drained by rclpy's own waits (the executor building its wait set each time, as every drain did "
          f"before the drain by takes): {waited_s / ticks * 1e6:.0f} µs/tick; main job / that floor "
          f"{job_s / waited_s:.2f}x")
    runtime_s = recorded["runtime_s"]
    alone_s = sum(runtime_s.values())
    print(f"the runtimes alone (their computation inside the main job, from the recording round): "
          + ", ".join(f"{name} {seconds / ticks * 1e6:.0f}" for name, seconds in sorted(runtime_s.items()))
          + f" µs/tick, {alone_s / ticks * 1e6:.0f} in all: the main job as built cannot go below the floor plus "
          f"that, {(floor_s + alone_s) / floor_s:.2f}x the floor")
    public_s = statistics.median(public)
    print(f"the main job without rclpy's internals (their public fallbacks): {public_s / ticks * 1e6:.0f} µs/tick, "
          f"{public_s / job_s:.2f}x the main job")
    print(f"main job / floor ratio: {job_s / floor_s:.2f}x")
    from headline import headline
    headline("main_job", "pmv simulate's pipeline, Kondor 10 Hz, per tick", job_s / ticks * 1e6, "µs/tick", "lower",
             floor_s / sum(published.values()) * 1e6, "µs/message",
             "bare rclpy publishing and taking one of its messages",
             ratio=job_s / ticks / (floor_s / sum(published.values())))


def _same_work(job: dict, other: dict) -> None:
    """Both runs of the main job took the same messages and aligned the same samples (else the times mean nothing)."""
    if (other["taken"], other["used"]) != (job["taken"], job["used"]):
        raise RuntimeError(f"the main job took {job['taken']} and used {job['used']} samples with rclpy's internals, "
                           f"{other['taken']} and {other['used']} without")


def compare_internals(ticks: int, rounds: int) -> None:
    """The main job with and without rclpy's internals, alternating; the ratio of every round and of the medians."""
    fenced, public, fenced_cpu, public_cpu = [], [], [], []
    for round_number in range(1, rounds + 1):
        job, unfenced = main_job(ticks), main_job(ticks, internals=False)
        _same_work(job, unfenced)
        fenced.append(job["wall_s"])
        public.append(unfenced["wall_s"])
        fenced_cpu.append(job["cpu_s"])
        public_cpu.append(unfenced["cpu_s"])
        print(f"round {round_number}: with rclpy's internals {job['wall_s']:.2f} s "
              f"({job['wall_s'] / ticks * 1e6:.0f} µs/tick), without {unfenced['wall_s']:.2f} s "
              f"({unfenced['wall_s'] / ticks * 1e6:.0f} µs/tick): {unfenced['wall_s'] / job['wall_s']:.2f}x "
              f"(load {os.getloadavg()[0]:.2f})")
    fenced_s, public_s = statistics.median(fenced), statistics.median(public)
    print(f"medians: with {fenced_s / ticks * 1e6:.0f} µs/tick, without {public_s / ticks * 1e6:.0f} µs/tick; by the "
          f"process's CPU time {statistics.median(public_cpu) / statistics.median(fenced_cpu):.2f}x; load average at "
          f"the end: {os.getloadavg()[0]:.2f}")
    print(f"main job without / with rclpy's internals: {public_s / fenced_s:.2f}x")


if __name__ == "__main__":
    main()
