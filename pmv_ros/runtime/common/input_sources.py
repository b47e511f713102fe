"""Where a node's inputs come from — one home, no ROS: one :class:`~.source_lock.SourceLock` per input, the
/clock check, the clock the locks measure silence on, and what all of them say on /diagnostics.

A node subscribes and asks its graph how many publishers a topic has; the state and the rules are here, so the
counters and the phrases are the same for every node and testable without a graph.
"""

from __future__ import annotations

from typing import Callable

from .source_lock import SourceLock
from .validation import ClockCheck, JumpDetector

#: How often (wall clock, s) the graph is asked how many publishers an input has.
GRAPH_CHECK_PERIOD_S = 1.0

#: The clock the source locks measure silence on: the node clock, with a single forged /clock
#: (back by more than 1 s, or ahead by more than 10 s) not believed until the next reading confirms it.
ARRIVAL_JUMP_BACK_S, ARRIVAL_JUMP_AHEAD_S = 1.0, 10.0


class InputSources:
    """The sources of one node's inputs: a lock per input topic, the /clock check, the arrival clock."""

    def __init__(self) -> None:
        self.locks = {}  # input topic (resolved name) → SourceLock
        self._streams = {}  # input topic (resolved name) → its counter key, from the name the node gave
        self.clock = ClockCheck(ARRIVAL_JUMP_BACK_S, ARRIVAL_JUMP_AHEAD_S)
        self._arrival = JumpDetector(ARRIVAL_JUMP_BACK_S, forward_threshold_s=ARRIVAL_JUMP_AHEAD_S)
        self._problems, self._checked_s = [], -float("inf")

    def lock(self, topic: str, given: str, timeout_s: float) -> SourceLock:
        """A new lock for the input ``topic`` (resolved in the node's namespace: one lock per spacecraft), counted
        under the name the node gave it (``given``: the same keys in any namespace)."""
        lock = self.locks[topic] = SourceLock(timeout_s)
        self._streams[topic] = given.strip("/").replace("/", "_")
        return lock

    def arrival_s(self, now_s: float) -> float:
        """The node clock ``now_s`` as the source locks see it (a jump counts once the next reading confirms it), s."""
        self._arrival.observe(now_s)
        return self._arrival.latest_s

    def set_timeout(self, timeout_s: float) -> None:
        """A new ``input.source_timeout_s`` for every input's lock (a parameter change)."""
        for lock in self.locks.values():
            lock.timeout_s = timeout_s

    def problems(self, now_s: float, wall_s: float, publishers: Callable[[str], int], clock_subscribed: bool,
                 max_age_s: float = GRAPH_CHECK_PERIOD_S) -> list[str]:
        """One phrase per input with more than one publisher (an ERROR on /diagnostics); [] when none has.

        ``publishers(topic)``: how many the graph knows; ``clock_subscribed``: /clock is an input (use_sim_time).
        The graph is asked at most every ``max_age_s`` of wall time ``wall_s`` (a caller with its own cadence
        passes 0); in between, the last phrases.
        """
        if wall_s - self._checked_s < max_age_s:
            return list(self._problems)
        self._checked_s, problems, now = wall_s, [], self.arrival_s(now_s)
        clocks = self.clock.sources.sources_heard(wall_s)
        if clock_subscribed:
            clocks = max(clocks, publishers("/clock"))
        if clocks > 1:
            problems.append(f"{clocks} publishers of /clock: only the first one heard sets the time "
                            f"({self.clock.counts['other_source']} messages of others dropped)")
        for topic, lock in self.locks.items():
            # A source the lock gave up for its silence has gone: a killed process lingers in the graph until the
            # middleware's lease ends, and is no second source beside its restarted self. (A second publisher that
            # talks is heard, whatever the graph says.)
            count = max(publishers(topic) - lock.lock_changes, lock.sources_heard(now))
            if count > 1:
                problems.append(f"{count} publishers of {topic}: only the first one heard is used "
                                f"({lock.other_source_messages} messages of others dropped)")
        self._problems = problems
        return list(problems)

    def counters(self) -> dict:
        """``other_source_<topic>``: messages dropped per input because a second publisher sent them;
        ``source_changes_<topic>``: sources given up after their silence and another taken;
        ``rejected_clock_<reason>``: /clock messages that did not set the time. Only those not zero."""
        counters = {}
        for topic, lock in self.locks.items():
            if lock.other_source_messages:
                counters[f"other_source_{self._streams[topic]}"] = lock.other_source_messages
            if lock.lock_changes:
                counters[f"source_changes_{self._streams[topic]}"] = lock.lock_changes
        counters.update({f"rejected_clock_{reason}": count for reason, count in self.clock.counts.items() if count})
        return counters
