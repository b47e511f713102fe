"""Refusals counted whole and said sparingly — one home, no ROS: :class:`RefusalTally`.

A request a node refuses (a parameter update, …) is counted on ``/diagnostics``
every time; the log says the first at once and then at most one line a
period with the count since, so a storm of refusals is a counter, never a
log line per request.
"""

from __future__ import annotations

#: Wall time between two log lines about refused requests of one kind, s (the first one is said at once): a storm
#: shows as one line a minute with its count — enough to see it go on, too little to drown the rest of the log.
REFUSAL_LOG_PERIOD_S = 60.0


class RefusalTally:
    """Requests refused (parameter updates, …): every one counted, the first said at once, then at most one
    line per ``period_s`` with the count since — a storm of refusals is a counter on /diagnostics, never a log
    line per request.

    Memory is bounded: one count and the time it was last said, whatever the requests were.
    """

    def __init__(self, what: str, period_s: float = REFUSAL_LOG_PERIOD_S) -> None:
        self.what = what
        self.period_s = float(period_s)
        self.count = 0
        self._said_s: float | None = None
        self._said_count = 0

    def refuse(self, reason: str, now_s: float) -> str | None:
        """Count one refusal for ``reason``; the line to log now, or None (said already in this period)."""
        self.count += 1
        if self._said_s is not None and now_s - self._said_s < self.period_s:
            return None
        since, self._said_s, self._said_count = self.count - self._said_count, now_s, self.count
        if since == 1:
            return f"refused {self.what}: {reason}"
        return (f"refused {self.what}: {reason} ({since} refused since the last line, {self.count} in all; "
                f"counted on /diagnostics, said at most every {self.period_s:g} s)")
