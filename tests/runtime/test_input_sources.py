"""What a node's input sources say on /diagnostics (pmv_ros.runtime.common.input_sources), without a graph."""

from __future__ import annotations

from pmv_ros.runtime.common.input_sources import InputSources


def _two_sources(sources: InputSources, topic: str, given: str) -> None:
    """A locked publisher (gid a) and a second one (gid b) on ``topic``: b's one message is dropped."""
    lock = sources.lock(topic, given, timeout_s=1.0)
    assert lock.admit(10.0, gid=b"a" * 16, sequence=1)
    assert not lock.admit(10.1, gid=b"b" * 16, sequence=1)


def test_counters_are_keyed_by_the_given_name_in_any_namespace_and_only_those_not_zero():
    sources = InputSources()
    _two_sources(sources, "/sat2/star_tracker/attitude", "star_tracker/attitude")
    sources.lock("/sat2/orbit/odometry", "orbit/odometry", timeout_s=1.0)  # one source: no counter
    assert sources.clock.admit(-1, 0, wall_s=0.0) == "negative"
    assert sources.counters() == {"other_source_star_tracker_attitude": 1, "rejected_clock_negative": 1}


def test_problems_name_every_crowded_input_from_the_graph_or_from_what_the_locks_heard():
    sources, graph = InputSources(), {"/clock": 2, "/pmv/attitude": 1, "/orbit/odometry": 3}
    _two_sources(sources, "/pmv/attitude", "pmv/attitude")  # the graph shows one; the lock heard two
    sources.lock("/orbit/odometry", "orbit/odometry", timeout_s=1.0)
    problems = sources.problems(10.2, wall_s=100.0, publishers=graph.get, clock_subscribed=False)
    assert problems == ["2 publishers of /pmv/attitude: only the first one heard is used (1 messages of others "
                        "dropped)", "3 publishers of /orbit/odometry: only the first one heard is used (0 messages "
                        "of others dropped)"]
    # /clock is an input only on simulation time; the graph is asked again only after max_age_s of wall time.
    graph["/orbit/odometry"] = 1
    assert sources.problems(10.3, wall_s=100.5, publishers=graph.get, clock_subscribed=True) == problems
    assert sources.problems(10.3, wall_s=101.0, publishers=graph.get, clock_subscribed=True) == [
        "2 publishers of /clock: only the first one heard sets the time (0 messages of others dropped)",
        "2 publishers of /pmv/attitude: only the first one heard is used (1 messages of others dropped)"]
    # Two seconds later on the node clock the second source has not been heard within the lock's timeout.
    assert sources.problems(12.3, wall_s=102.0, publishers=graph.get, clock_subscribed=False) == []


def test_the_arrival_clock_believes_a_jump_only_when_the_next_reading_confirms_it():
    sources = InputSources()
    assert sources.arrival_s(100.0) == 100.0
    assert sources.arrival_s(5000.0) == 100.0  # a single forged /clock far ahead: not believed
    assert sources.arrival_s(100.1) == 100.1
    assert sources.arrival_s(5000.0) == 100.1
    assert sources.arrival_s(5000.1) == 5000.1  # confirmed by the next reading


def test_a_restarted_source_is_not_a_second_one_while_its_dead_self_lingers_in_the_graph():
    # kill -9 and respawn: the old publisher stays in the graph until the middleware's lease ends (≈ 15 s); the
    # lock gave it up after its silence and took the new one. One source, no ERROR.
    sources, graph = InputSources(), {"/pmv/attitude": 2}
    lock = sources.lock("/pmv/attitude", "pmv/attitude", timeout_s=1.0)
    assert all(lock.admit(0.1 * k, sequence=k, stamp_s=0.1 * k) for k in range(1, 30))   # to 2.9 s
    assert all(lock.admit(6.1 + 0.1 * k, sequence=k, stamp_s=6.1 + 0.1 * k) for k in range(1, 20))  # 3.2 s later
    assert lock.lock_changes == 1
    assert sources.problems(8.0, wall_s=100.0, publishers=graph.get, clock_subscribed=False) == []
    assert sources.counters() == {"source_changes_pmv_attitude": 1}
    # A third publisher that talks is a second source, whatever the graph says.
    assert not lock.admit(8.05, sequence=1, stamp_s=8.05)
    assert sources.problems(8.1, wall_s=101.0, publishers=graph.get, clock_subscribed=False) == [
        "2 publishers of /pmv/attitude: only the first one heard is used (1 messages of others dropped)"]
