"""error_monitor_node's work without ROS: inputs fed to the monitor, the statistics schedule, the health status.

:class:`MonitorRuntime` puts the node's input side in front of
:class:`~pmv_ros.runtime.monitor.core.ErrorMonitor`: the sensor's samples take the
orbit of the odometry (or no oblateness model left when the sensor removes
it on board, :func:`oblateness_override`, as the campaign's flight does);
the statistics come every ``1/statistics_rate_hz`` seconds of sample time
(:class:`MonitorStatistics`, with the numbers the ``pmv/residual_<name>``
vectors carry); :meth:`MonitorRuntime.health` is the ``/diagnostics``
status. Each input returns a :class:`MonitorOutput`.

The node hands over the messages of one executor wake-up at once
(:meth:`MonitorRuntime.add_inputs`): they go to the monitor as one input, so
its fixed cost (a settle of what they make due) is paid once per wake-up,
not per message; the one-message inputs (:meth:`~MonitorRuntime.add_sensor`,
:meth:`~MonitorRuntime.add_truth`, :meth:`~MonitorRuntime.add_odometry`) are
batches of one. What comes out, and in which order, does not depend on
where the messages are cut: a batch is cut only after a sensor sample at
which the statistics fall due, and the statistics then are those of that
moment.

Bad input is dropped before it touches any state and counted per reason
(``rejected_<stream>_<reason>``: the checks of :mod:`pmv_ros.runtime.common.validation`,
with the ``input.*`` plausibility bounds), messages the shim cannot read as
``rejected_<stream>_unreadable``, messages stamped in another frame than their
stream's (``frames.*``: angles in the sensor frame, truth in the orbital one,
odometry from ``eci`` to the orbital frame) as
``rejected_<stream>_wrong_frame`` — the first such refusal is said on the
log once, with the frame expected and the frame that came, and
``/diagnostics`` names it while the refusals last; only accepted sensor
samples drive the statistics schedule. The node uses only the first publisher heard on each
input; a second one is an ERROR on ``/diagnostics`` with the publishers'
count and its messages are dropped (``other_source_<topic>``). Outages, restarts and clock
jumps: README "Truth outages and discontinuities" and the core monitor's
docstring — in short, nothing is interpolated across a gap, a confirmed jump
back resets the alignment once, a single forged jump is an outlier, a
parameter change starts the statistics over.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from ...analysis.statistics import CHANNELS
from ...physics.constants import ARCMIN_RAD
from ..common.assembly import orbit_bounds
from ..common.frames import Frames
from .core import ErrorMonitor
from .lost_truth import WANT_OF_TRUTH, LostTruth
from .records import (BATCH_STATUSES, ODOMETRY_EVENT, SENSOR_EVENT, TRUTH_EVENT, BatchOutcome, Feed, MonitorConfig,
                      MonitorSummary, Outcome, Status)
from ..common.records import HealthSummary, Level, LogLine
from ..common.validation import FrameCheck, Rejection

#: The numeric statistics topics (``pmv/residual_<name>``) and the channel statistic each carries, rad;
#: "limit" is the half-width 3σ of the bound mean ± 3σ (``three_sigma_arcmin`` on /pmv/error_statistics).
STATISTICS_VECTORS = {"mean": "mean_rad", "sigma": "sigma_rad", "limit": "three_sigma_rad"}

#: Relative difference between the orbital period of /orbit/odometry and the configured one
#: above which /diagnostics warns: the harmonics are fitted on the configured period.
PERIOD_MISMATCH = 0.01

#: The batch status codes of a sample that had no truth around it.
_WANT_OF_TRUTH_CODES = np.array([BATCH_STATUSES.index(status) for status in WANT_OF_TRUTH])

#: Counters the health status shows when not zero, besides the skipped and rejected ones.
_SHOWN_COUNTERS = ("truth_quaternions_normalised", "clock_jumps", "clock_outliers", "alignment_resets")


def build_monitor(values: dict) -> ErrorMonitor:
    """The monitor core from parameter values; ValueError if inconsistent."""
    return ErrorMonitor(MonitorConfig.for_orbit(
        values["orbit.altitude_km"] * 1e3, math.radians(values["orbit.inclination_deg"]),
        remove_oblateness=values["remove_oblateness"],
        max_truth_gap_s=values["max_truth_gap_s"],
        max_truth_wait_s=values["max_truth_wait_s"],
        clock_jump_s=values["clock_jump_s"],
        future_tolerance_s=values["future_tolerance_s"],
        roll_offset_rad=values["roll_offset_arcmin"] * ARCMIN_RAD,
        pitch_offset_rad=values["pitch_offset_arcmin"] * ARCMIN_RAD,
        min_interval_s=1.0 / values["input.max_rate_hz"],
        bounds=orbit_bounds(values, max_abs_angle_rad=math.radians(values["input.max_abs_angle_deg"])),
    ))


def oblateness_override(values: dict) -> dict:
    """The oblateness model to give the monitor with each sensor sample, beside the odometry's.

    ``sensor.oblateness_compensation``: removed on board already, the model left in the sensor's output is
    zero; otherwise nothing (the monitor takes the model from the orbit).
    """
    if values["sensor.oblateness_compensation"]:
        return {"oblateness_roll_rad": 0.0, "oblateness_pitch_rad": 0.0}
    return {}


class MonitorStatistics:
    """The statistics at sample time ``stamp_s``: the monitor's summary and, per :data:`STATISTICS_VECTORS`
    name, the (roll, pitch, meridional) values in rad (NaN while pending).

    Both are made at their first read, from what the monitor held at ``stamp_s``
    (:meth:`~pmv_ros.runtime.monitor.core.ErrorMonitor.summary_later`): once the ring holds an orbit, the
    harmonic fit costs ≈ 1 ms, and in a private graph (``pmv simulate``) most statistics are read by nobody.
    """

    def __init__(self, stamp_s: float, summary: Callable[[], MonitorSummary]) -> None:
        self.stamp_s = stamp_s
        self._summary = summary

    @cached_property
    def summary(self) -> MonitorSummary:
        """The monitor's summary at ``stamp_s``."""
        return self._summary()

    @cached_property
    def vectors(self) -> dict:
        """Per :data:`STATISTICS_VECTORS` name, the (roll, pitch, meridional) values, rad."""
        return {name: tuple(getattr(self.summary.channel(channel), statistic) for channel in CHANNELS)
                for name, statistic in STATISTICS_VECTORS.items()}


@dataclass
class MonitorOutput:
    """What inputs make the monitor publish, in order: residuals (:class:`~pmv_ros.runtime.monitor.records.Outcome`
    items, OK ones) and :class:`MonitorStatistics` when due; and ``log`` lines for the node's log."""

    published: list = field(default_factory=list)
    log: list = field(default_factory=list)  #: :class:`~pmv_ros.runtime.common.records.LogLine` items

    @property
    def residuals(self) -> list[Outcome]:
        """The aligned samples' outcomes, in order."""
        return [item for item in self.published if type(item) is Outcome]

    @property
    def statistics(self) -> MonitorStatistics | None:
        """The last statistics published (None: none)."""
        computed = [item for item in self.published if type(item) is MonitorStatistics]
        return computed[-1] if computed else None


class _Batch:
    """Messages gathered for one monitor input (a :class:`~pmv_ros.runtime.monitor.records.Feed` with its order)."""

    def __init__(self) -> None:
        self.order, self.sensor, self.truth, self.odometry = [], ([], [], [], []), ([], [], []), ([], [], [], [])

    def add(self, kind: int, columns: tuple, values: tuple) -> None:
        self.order.append((kind, len(columns[0])))
        for column, value in zip(columns, values):
            column.append(value)

    def feed(self, values: dict) -> Feed:
        (t, roll, pitch, now), (truth_t, q, truth_now), (odometry_t, position, velocity, odometry_now) = (
            self.sensor, self.truth, self.odometry)
        model = [0.0] * len(t) if oblateness_override(values) else None
        return Feed(t, roll, pitch, now, truth_t_s=truth_t, truth=q, truth_now_s=truth_now, odometry_t_s=odometry_t,
                    odometry_position_m=position, odometry_velocity_m_s=velocity, odometry_now_s=odometry_now,
                    odometry_max_age_s=values["odometry_timeout_s"], model_roll_rad=model, model_pitch_rad=model,
                    order=self.order)


class MonitorRuntime:
    """The error monitor fed from the node's three inputs, with its statistics schedule and health.

    Args:
        values: error_monitor_node parameter values.
        source_problems: ``() -> list`` of phrases about second sources of an input (the node's graph):
            an ERROR on /diagnostics.
        source_counters: ``() -> dict`` of the node's input-source counters, for /diagnostics.

    Raises ValueError for a combination of values the parameter ranges cannot check.
    """

    def __init__(self, values: dict, *, source_problems: Callable[[], list] = list,
                 source_counters: Callable[[], dict] = dict) -> None:
        self.frames = Frames.from_values(values)
        self.monitor = build_monitor(values)
        self.lost_truth = LostTruth(values["max_truth_gap_s"])  # samples without truth, by the tracker's reason
        self.values = values
        self._source_problems, self._source_counters = source_problems, source_counters
        self.statistics_epochs, self._epoch_phrase = 0, None
        # What is refused before the monitor sees it (fixed keys: memory stays bounded).
        self.rejected_messages = {f"rejected_{stream}_{reason}": 0 for stream in ("sensor", "truth", "odometry")
                                  for reason in ("unreadable", Rejection.WRONG_FRAME.value)}
        self.rejected_messages["rejected_frame_status_unreadable"] = 0
        # Each input's frame checks, with their words (odometry: the pose's frame and the twist's child frame).
        frames = self.frames
        self._frame_checks = {"sensor": (FrameCheck("sensor angles", frames.sensor),),
                              "truth": (FrameCheck("star-tracker truth", frames.orbital),),
                              "odometry": (FrameCheck("odometry pose", frames.eci),
                                           FrameCheck("odometry child frame", frames.orbital))}
        self._next_statistics_s = None
        self._rejected_reported = 0
        self.latest_statistics = None  # the last MonitorStatistics computed (:meth:`statistics`)

    def new_epoch(self, topic: str) -> None:
        """Another source took ``topic`` (a sensor restarted: its orbit and its timeline start again): new
        statistics, counted (``statistics_epochs``) and said once on /diagnostics."""
        self.monitor.new_epoch()
        self._next_statistics_s = None
        self.statistics_epochs += 1
        self._epoch_phrase = (f"statistics epoch {self.statistics_epochs + 1}: a new source of {topic}, "
                              "statistics started over")

    def reconfigure(self, values: dict) -> None:
        """New parameter values: new statistics (mixing two configurations would mean nothing)."""
        self.monitor = build_monitor(values)
        self.lost_truth = LostTruth(values["max_truth_gap_s"])
        self._next_statistics_s = None
        self.values = values

    # -- inputs ------------------------------------------------------------------------------------

    def _in_frame(self, stream: str, output: MonitorOutput, *frame_ids: str) -> bool:
        """Whether a message of ``stream`` is stamped in the frames the stream expects (odometry: pose, then child
        frame); counts it as rejected when not, and the first such refusal of each check goes to the log (once)."""
        for check, frame_id in zip(self._frame_checks[stream], frame_ids):
            rejection = check.check(frame_id)
            if rejection is not None:
                self.rejected_messages[f"rejected_{stream}_{rejection.value}"] += 1
                line = check.take_log_line()
                if line is not None:
                    output.log.append(LogLine("error", line))
                return False
        return True

    def frame_problems(self) -> list[str]:
        """What /diagnostics says while an input's messages are refused for their frame (expected, got), if any."""
        return [check.problem for checks in self._frame_checks.values() for check in checks
                if check.problem is not None]

    def _readable(self, stream: str, value) -> bool:
        if value is None:
            self.rejected_messages[f"rejected_{stream}_unreadable"] += 1
        return value is not None

    def add_inputs(self, events) -> MonitorOutput:
        """Messages in arrival order, as the node queued them in one executor wake-up: each ``(input, its
        arguments, node clock s or None)`` with the input one of ``"add_sensor"``, ``"add_truth"``,
        ``"add_odometry"`` and the arguments those take (below). What they make the node publish, in order: what
        those methods give one message at a time, with the monitor fed once for the whole batch — cut only after a
        sensor sample at which the statistics fall due (at most ``statistics_rate_hz`` times a second of samples).
        """
        output, batch = MonitorOutput(), _Batch()
        for to, arguments, now_s in events:
            if to == "add_sensor":
                frame_id, stamp_s, roll_rad, pitch_rad = arguments
                if self._in_frame("sensor", output, frame_id) and self._readable("sensor", stamp_s):
                    batch.add(SENSOR_EVENT, batch.sensor, (stamp_s, roll_rad, pitch_rad, now_s))
                    if self._statistics_due(stamp_s):
                        self._give(batch, output, stamp_s)
                        batch = _Batch()
            elif to == "add_truth":
                frame_id, stamp_s, q_xyzw = arguments
                if self._in_frame("truth", output, frame_id) and self._readable("truth", stamp_s):
                    batch.add(TRUTH_EVENT, batch.truth, (stamp_s, q_xyzw, now_s))
            elif to == "add_odometry":
                frame_id, child_frame_id, state = arguments
                # nav_msgs: the pose in ``frame_id`` (ECI), the twist in ``child_frame_id`` (orbital).
                if self._in_frame("odometry", output, frame_id, child_frame_id) and self._readable("odometry", state):
                    batch.add(ODOMETRY_EVENT, batch.odometry, (*state, now_s))
            elif to == "add_frame_status":  # the tracker's frame: why it has no attitude, if it has none
                stamp_s, reason = arguments
                if self._readable("frame_status", stamp_s):
                    self.lost_truth.add_status(stamp_s, reason)
            else:
                raise ValueError(f"error monitor: no input {to!r}")
        self._give(batch, output)
        return output

    def _give(self, batch: _Batch, output: MonitorOutput, due_s: float | None = None) -> None:
        """Feed ``batch`` to the monitor; the residuals, then the statistics if the sample it ends with at
        ``due_s`` was not refused (a refused sample must not move the statistics schedule)."""
        if not batch.order:
            return
        outcomes, refused = self.monitor.add_inputs(batch.feed(self.values),
                                                    None if due_s is None else len(batch.sensor[0]) - 1)
        output.published += self._used(outcomes)
        if due_s is not None and not refused:
            output.published.append(self._statistics_when_due(due_s))

    def add_odometry(self, frame_id: str, child_frame_id: str, state, now_s: float | None) -> MonitorOutput:
        """One /orbit/odometry message: ``state`` (stamp s, position m, velocity m/s in ECI), None if unreadable.
        Validated (a bound Earth orbit, sane stamps) and kept in the monitor; a confirmed clock jump resets there."""
        return self.add_inputs([("add_odometry", (frame_id, child_frame_id, state), now_s)])

    def add_frame_status(self, stamp_s: float | None, reason: str | None, now_s: float | None) -> MonitorOutput:
        """One /star_tracker/frame_status: a tracker frame's time and reason ("ok" or why it has no attitude; None:
        unreadable), for the samples without truth (:attr:`truth_lost`)."""
        return self.add_inputs([("add_frame_status", (stamp_s, reason), now_s)])

    def add_truth(self, frame_id: str, stamp_s: float | None, q_xyzw, now_s: float | None) -> MonitorOutput:
        """One star-tracker attitude (orbital → body, x, y, z, w) at ``stamp_s`` (None: unreadable)."""
        return self.add_inputs([("add_truth", (frame_id, stamp_s, q_xyzw), now_s)])

    def add_sensor(self, frame_id: str, stamp_s: float | None, roll_rad: float, pitch_rad: float,
                   now_s: float | None) -> MonitorOutput:
        """One sensor sample (roll, pitch, rad) at ``stamp_s`` (None: unreadable); the statistics when due."""
        return self.add_inputs([("add_sensor", (frame_id, stamp_s, roll_rad, pitch_rad), now_s)])

    def add_stream(self, t_s, roll_rad, pitch_rad, truth_t_s, q_truth, truth_arrival, position_eci_m,
                   velocity_eci_m_s, now_s=None) -> BatchOutcome:
        """A whole clean stream at once (a campaign's flight): what the three inputs would do message by message
        — truth j arriving just before sensor sample ``truth_arrival[j]``, then the odometry at the sample's
        stamp, then the sample, the node clock ``now_s`` ``(N,)`` at each (default: the sample's stamp). Arrays as
        :meth:`~pmv_ros.runtime.monitor.core.ErrorMonitor.add_batch` takes them; the statistics schedule is not run."""
        batch = self.monitor.add_batch(t_s, roll_rad, pitch_rad, truth_t_s, q_truth, truth_arrival,
                                       now_s=t_s if now_s is None else now_s,
                                       odometry=(position_eci_m, velocity_eci_m_s), **self._sample_orbit())
        self._used(batch.earlier)
        self.lost_truth.count(np.asarray(t_s, float)[np.isin(batch.status, _WANT_OF_TRUTH_CODES)])
        return batch

    def _used(self, outcomes: list) -> list:
        """The used samples of ``outcomes``; those without truth counted by the tracker's reason on the way."""
        lost = [outcome.stamp_s for outcome in outcomes if outcome.status in WANT_OF_TRUTH]
        if lost:
            self.lost_truth.count(lost)
        return [outcome for outcome in outcomes if outcome.status is Status.OK]

    @property
    def truth_lost(self) -> dict:
        """Samples skipped for want of truth, by the star tracker's reason (``truth_lost_<reason>``; a copy)."""
        return dict(self.lost_truth.counts)

    def _sample_orbit(self) -> dict:
        """How a sensor sample gets its oblateness model: from the odometry no older than odometry_timeout_s, or
        none left in it when the sensor removes it on board (:func:`oblateness_override`)."""
        return dict(odometry_max_age_s=self.values["odometry_timeout_s"], **oblateness_override(self.values))

    def poll(self, now_s: float | None) -> MonitorOutput:
        """The node clock's tick: samples that waited too long for truth are settled."""
        return MonitorOutput(self._used(self.monitor.poll(now_s)))

    # -- outputs -----------------------------------------------------------------------------------

    def _statistics_due(self, stamp_s: float) -> bool:
        """Whether a sample at ``stamp_s`` that is not refused makes the statistics due (see below)."""
        following = self._next_statistics_s
        return (following is None or stamp_s >= following
                or stamp_s < following - 1.0 / self.values["statistics_rate_hz"])

    def _statistics_when_due(self, stamp_s: float) -> MonitorStatistics | None:
        period = 1.0 / self.values["statistics_rate_hz"]
        if self._next_statistics_s is None or stamp_s < self._next_statistics_s - period:
            self._next_statistics_s = stamp_s  # first sample, or the clock went back
        if stamp_s < self._next_statistics_s:
            return None
        self._next_statistics_s = stamp_s + period
        return self.statistics(stamp_s)

    def statistics(self, stamp_s: float) -> MonitorStatistics:
        """The current statistics, stamped ``stamp_s`` (s); kept as :attr:`latest_statistics`."""
        self.latest_statistics = MonitorStatistics(stamp_s, self.monitor.summary_later())
        return self.latest_statistics

    def period_mismatch(self) -> str | None:
        """A warning when /orbit/odometry flies another orbit than the parameters describe, else None."""
        measured_s = self.monitor.odometry_period_s
        if measured_s is None:
            return None
        configured_s = self.monitor.config.orbital_period_s
        if abs(measured_s - configured_s) <= PERIOD_MISMATCH * configured_s:
            return None
        return (f"/orbit/odometry gives an orbital period of {measured_s:.0f} s, the parameters "
                f"{configured_s:.0f} s: harmonics are fitted on the parameters' period (set orbit.altitude_km)")

    def health(self, now_s: float | None) -> HealthSummary:
        """The /diagnostics status at node clock ``now_s`` (None: unknown): what was skipped and rejected,
        the truth's age, second sources (an ERROR) and a period the odometry contradicts."""
        counters = self.monitor.counters
        skipped = {k: v for k, v in counters.items() if k.startswith("skipped_") and v}
        rejected = {k: v for k, v in counters.items() if k.startswith("rejected_") and v}
        rejected.update({k: v for k, v in self.rejected_messages.items() if v})
        problems = self._source_problems()  # a second publisher on an input: ERROR
        source_error = bool(problems)
        problems += self.frame_problems()  # what was expected, what came
        latest_truth = self.monitor.latest_truth_stamp_s
        if counters["truth_received"] == 0:
            if not self._frame_checks["truth"][0].refused:  # else the refusal above says why there is none
                problems.append("no star-tracker truth received yet")
        elif now_s is not None and latest_truth is not None and now_s - latest_truth > self.values["max_truth_wait_s"]:
            problems.append(f"no star-tracker truth for {now_s - latest_truth:.0f} s")
        # Samples waiting for truth are normal (the star tracker's latency); an outage shows as truth age above.
        mismatch = self.period_mismatch()
        if mismatch is not None:
            problems.append(mismatch)
        if self._epoch_phrase is not None:  # said once
            problems.append(self._epoch_phrase)
            self._epoch_phrase = None
        rejected_total = sum(rejected.values())
        if rejected_total > self._rejected_reported:
            problems.append("rejected input messages")
        self._rejected_reported = rejected_total
        level = Level.ERROR if source_error else Level.WARN if problems else Level.OK
        lost = {k: v for k, v in self.lost_truth.counts.items() if v}
        values = {"used": counters["used"], **skipped, **lost, **rejected, **self._source_counters(),
                  **{k: counters[k] for k in _SHOWN_COUNTERS if counters[k]},
                  **({"statistics_epochs": self.statistics_epochs} if self.statistics_epochs else {}),
                  "pending": self.monitor.pending_count, "truth_buffer": self.monitor.truth_buffer_length}
        return HealthSummary(level, "; ".join(problems) if problems else "aligned with truth", values)
