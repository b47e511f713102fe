"""Is the simulation clock moving? A ``/clock`` that stops while the nodes run, seen on the wall clock.

A node on ``use_sim_time`` does nothing while its ``/clock`` stands still:
its timers run on that clock, so its own health reports stop too and
nothing would say why the outputs stopped. :class:`ClockWatch` is asked on
the wall clock (the node's steady timer) and says when the simulation time
has not moved for :data:`CLOCK_STALL_S` of wall time — a WARN on
``/diagnostics`` (interfaces.md "Time") — and when it moves again.
"""

from __future__ import annotations

import math

from .records import HealthSummary, Level

#: Wall time without a change of the simulation clock after which it is reported stopped, s. A
#: simulator's /clock ticks at tens to hundreds of Hz; even a coarse one stepping once a second stays
#: under this. A stop is said within this plus two watch periods (CLOCK_WATCH_PERIOD_S: the last change
#: is seen up to one period late, the stall up to one period late): 2 s.
CLOCK_STALL_S = 1.5

#: How often (wall clock, s) a node asks its watch; while the clock stands the WARN is repeated this often.
CLOCK_WATCH_PERIOD_S = 0.25


class ClockWatch:
    """Watches one node's simulation clock on the wall clock.

    Args:
        stall_after_s: wall time without a change of the clock after which it is stopped, s.
    """

    def __init__(self, stall_after_s: float = CLOCK_STALL_S):
        if not (math.isfinite(stall_after_s) and stall_after_s > 0.0):
            raise ValueError(f"a clock stall time of {stall_after_s} s is not a positive number of seconds")
        self.stall_after_s = float(stall_after_s)
        self._clock_s: float | None = None
        self._changed_wall_s = 0.0
        self.stalled = False
        self.stalls = 0  #: how many times the clock stopped

    def observe(self, clock_s: float, wall_s: float) -> HealthSummary | None:
        """Take one reading of the simulation clock (s; 0: no /clock yet) at wall time ``wall_s`` (s, monotonic).

        Returns a status to publish — a WARN at each reading while the clock
        stands, one OK when it moves again, with ``clock_stalls`` (:attr:`stalls`)
        — or None when there is nothing to say.
        """
        if self._clock_s is None or clock_s != self._clock_s:
            was_stalled = self.stalled
            self._clock_s, self._changed_wall_s, self.stalled = clock_s, wall_s, False
            if was_stalled:
                return self._report(Level.OK, f"/clock moves again (simulation time {clock_s:.3f} s)")
            return None
        if clock_s <= 0.0:  # no /clock yet: waiting for a simulator is not a stall
            return None
        still_s = wall_s - self._changed_wall_s
        if still_s < self.stall_after_s:
            return None
        if not self.stalled:
            self.stalled, self.stalls = True, self.stalls + 1
        return self._report(Level.WARN, f"/clock has not moved for {still_s:.1f} s of wall time (simulation time "
                                        f"stands at {clock_s:.3f} s): no samples until it moves")

    def _report(self, level: Level, message: str) -> HealthSummary:
        return HealthSummary(level, message, {"clock_stalls": self.stalls})
