"""What the sensor says about its own health: chord conditions, input counters, the truth it follows.

sensor_node publishes :meth:`SensorHealth.report` on ``/diagnostics``
whenever it is due: every ``period_s`` of sample time, and at once when the
condition changes (a chord lost or regained, truth going stale). Levels are
:class:`pmv_ros.runtime.common.records.Level` (the ``diagnostic_msgs`` values).
"""

from __future__ import annotations

import math

from ...physics.orbit.ephemeris import BODY_NAMES
from ...physics.geometry import CHORD_NAMES
from ...physics.instrument.sensor import ChordStatus
from ..common.records import HealthSummary, Level
from ..common.truth_buffer import TruthAt


def chord_problems(status, blinding, exclusion_deg: float) -> list[str]:
    """One phrase per invalid chord of one sample: which chord, and why."""
    problems = []
    for chord, code, body in zip(CHORD_NAMES, status, blinding):
        if code == ChordStatus.SUN_OR_MOON:
            problems.append(f"chord {chord}: {BODY_NAMES[body]} in the field of view (within "
                            f"{exclusion_deg:g} deg)")
        elif code == ChordStatus.NO_HORIZON:
            problems.append(f"chord {chord}: no horizon in the scan")
        elif code == ChordStatus.NOT_DETECTED:
            problems.append(f"chord {chord}: no crossing detected")
    return problems


def truth_source_warnings(other_publishers: int) -> tuple:
    """What to say when a sensor flying its own attitude model sees ``other_publishers`` of /attitude/truth
    besides itself (a following sensor's second source is the source lock's ERROR instead)."""
    if other_publishers > 0:
        return ("another publisher of /attitude/truth besides this sensor's own attitude model (to follow it, "
                "give config/follow.yaml after the preset — README \"Follow mode\")",)
    return ()


class SensorHealth:
    """Counters and condition of one sensor, and when to report them.

    Counters have fixed sets of keys (chord × status, input reasons), so
    memory stays bounded however long the node runs.
    """

    def __init__(self, truth_topic: str = "/attitude/truth", odometry_topic: str = "/orbit/odometry"):
        """``truth_topic``, ``odometry_topic``: the node's resolved input names (in a namespace, its own)."""
        self.truth_topic, self.odometry_topic = truth_topic, odometry_topic
        self.samples_published = 0
        self._chord_counts = [[0] * 4 for _ in ChordStatus]  # [status][chord]
        self._counters = {}  # reason → count
        self._rejected_reported = {"truth": 0, "odometry": 0}  # rejected messages per input, last reported
        self._last_report_s = -math.inf
        self._last_condition = ()

    def count(self, reason: str) -> None:
        """Count one event under ``reason`` (``rejected_truth_<reason>``, ``skipped_<reason>``, ...)."""
        self._counters[reason] = self._counters.get(reason, 0) + 1

    @property
    def counters(self) -> dict:
        """The input counters (a copy)."""
        return dict(self._counters)

    def record_sample(self, status) -> None:
        """Count one published sample and its chords' status codes."""
        for chord, code in enumerate(status):
            self._chord_counts[code][chord] += 1
        self.samples_published += 1

    def report(self, t_s: float, period_s: float, *, status=None, blinding=None, truth: TruthAt | None = None,
               exclusion_deg: float = 0.0, truth_age_s: float = math.nan, warnings=(),
               no_sample: str | None = None) -> HealthSummary | None:
        """The status to publish at sample time ``t_s``, or None when none is due.

        Args:
            status, blinding: this sample's chord codes and blinding bodies (None: no sample).
            truth: in follow mode, where the attitude of this tick came from.
            truth_age_s: in follow mode, how old the newest truth is at ``t_s``.
            warnings: further problems the node found (two publishers of /attitude/truth, ...).
            no_sample: why there is no sample (status None); None: no truth at the sample time (follow mode).
        """
        stale = truth is TruthAt.STALE
        condition = (() if status is None else (tuple(status), tuple(blinding)), stale, tuple(warnings))
        due = t_s - self._last_report_s >= period_s or t_s < self._last_report_s  # back: a new run
        if not due and condition == self._last_condition:
            return None
        self._last_report_s, self._last_condition = t_s, condition
        problems = [] if status is None else chord_problems(status, blinding, exclusion_deg)
        values = {"samples_published": self.samples_published}
        if status is not None:
            values.update({f"chord_{chord}": ChordStatus(int(code)).name.lower()
                           for chord, code in zip(CHORD_NAMES, status)})
        for code in ChordStatus:
            if code != ChordStatus.VALID:
                for chord, count in zip(CHORD_NAMES, self._chord_counts[code]):
                    if count:
                        values[f"{code.name.lower()}_{chord}"] = int(count)
        values.update(self._counters)
        if truth is not None:
            values["truth"] = truth.value
            if math.isfinite(truth_age_s):
                values["truth_age_s"] = f"{truth_age_s:.3f}"
        fresh = []
        for stream, topic in (("truth", self.truth_topic), ("odometry", self.odometry_topic)):
            rejected = sum(n for reason, n in self._counters.items() if reason.startswith(f"rejected_{stream}_"))
            if rejected > self._rejected_reported[stream]:
                fresh.append(f"rejected {topic} messages")
            self._rejected_reported[stream] = rejected
        level = Level.OK
        if stale:
            problems.append(f"stale {self.truth_topic}: the newest is {truth_age_s:.3f} s old, beyond the "
                            "extrapolation horizon; no angles are published")
            level = Level.ERROR
        elif status is None:
            problems.append(f"no sample: {no_sample or f'no {self.truth_topic} at the sample time'}"
                            + ("" if truth is None else f" ({truth.value.replace('_', ' ')})"))
        problems.extend(fresh)
        problems.extend(warnings)
        if problems and level == Level.OK:
            level = Level.WARN
        return HealthSummary(level, "; ".join(problems) if problems else "all chords valid", values)
