"""The error monitor without ROS: align the sensor with star-tracker truth, keep live statistics.

:class:`ErrorMonitor` is what ``error_monitor_node`` wraps. It takes truth
samples (t, roll, pitch) — or star-tracker quaternions — and sensor samples
(t, roll, pitch, plus the orbit position for the oblateness model), and for
each sensor sample returns an :class:`Outcome`: the residual sensor − truth,
or the reason it could not be used. Times are seconds (float) on the node
clock; angles radians.

Alignment (physics.md §6: truth has noise, latency and gaps)
    Truth is interpolated linearly in roll and pitch between the two truth
    samples that bracket the sensor stamp, never across a gap longer than
    ``max_truth_gap_s``. A sensor sample newer than the latest truth waits in
    a bounded pending queue until truth at or after its stamp arrives, so the
    residual of a sample comes out with the truth latency plus up to one
    truth interval of delay; a sample that waits longer than
    ``max_truth_wait_s`` (measured by the newer sensor stamps or by ``now_s``)
    is given up as ``stale_truth`` — that is what a star-tracker outage
    produces, and alignment resumes by itself when truth returns.

Validation (issues 6 and 15; the checks are :mod:`pmv_ros.runtime.validation`)
    Every incoming sample is checked before it touches any state: non-finite
    values, a zero (unset) or negative stamp, a stamp in the future of
    ``now_s``, a duplicate or backwards stamp, one stamped faster than the
    stream may be (``min_interval_s``), a quaternion far from unit norm
    (near-unit ones are normalised and counted), a sensor angle beyond the
    plausibility bound, an orbit state that is not a bound Earth orbit. So no
    statistic can become non-finite: every value that reaches one is finite
    and bounded.

Clock jumps (the rule of :class:`~pmv_ros.runtime.validation.JumpDetector`)
    A stamp that goes back by more than ``clock_jump_s`` — or a ``now_s``
    that does, or leaps ahead by more than ``max_truth_wait_s`` — is a *suspected* jump; the next
    observation decides. If it continues the new timeline the jump is real
    (simulation restarted, a node restarted on a new clock): the alignment
    state and the harmonic ring are reset once, so that nothing is
    interpolated or fitted across the discontinuity, while the running
    statistics, which are sums over valid residuals, carry on. If it is back
    on the old timeline the jump was a single outlier (a forged ``/clock``, a
    mis-stamped message): counted ``clock_outliers``, and the ring and the
    alignment are kept. While a jump of ``now_s`` is unconfirmed, the old
    clock is used. :meth:`ErrorMonitor.reset` clears everything.

Statistics
    Per channel roll, pitch, meridional, both with the oblateness model
    removed and kept (``remove_oblateness`` picks the one reported by
    default): running count, mean, σ (N − 1), 3σ, max |e|
    (:class:`~pmv_ros.analysis.statistics.RunningStatistics`); harmonic
    amplitudes over the last full orbit from a fixed-size ring
    (:class:`~pmv_ros.analysis.statistics.OrbitRing`); and the residual as the
    ground error of a nadir imager (physics.md §7): cross-track for roll,
    along-track for pitch, circular for meridional. Memory is bounded
    whatever the run length: fixed counters, fixed ring, truth buffer and
    pending queue capped.

Batches
    :meth:`ErrorMonitor.add_batch` takes a whole stretch of sensor, truth and
    odometry samples in arrival order (``pmv campaign`` flies a task through
    it): every input passes the same checks one by one, then the alignment
    and statistics run on arrays; a batch the array form cannot follow
    exactly (a clock jump, samples already pending, …) is fed sample by
    sample. Either way the outcome is the per-sample one.

Not thread-safe: call it from one executor thread.
"""

from __future__ import annotations

import bisect
import math
from collections import deque


from ..physics.attitude import true_roll_pitch
from ..physics.oblateness import closed_form_oblateness
from .validation import (
    Jump,
    JumpDetector,
    Rejection,
    StampCheck,
    check_angles,
    check_orbit_state,
    check_quaternion,
)
from ..analysis.statistics import (
    CHANNELS,
    ChannelStatistics,
    DEFAULT_MAX_CONDITION,
    OrbitRing,
)


from .monitor_batch import BatchFeeding
from .monitor_records import (
    COUNTER_NAMES,
    MonitorConfig,
    MonitorSummary,
    Outcome,
    PendingSample,
    StatisticsSet,
    Status,
    ground_components,
    orbit_record,
)


class ErrorMonitor(BatchFeeding):
    """Align sensor roll/pitch with star-tracker truth and keep live error statistics (physics.md §5, §5.1, §6, §7).

    Feed it with :meth:`add_truth` (or :meth:`add_truth_quaternion`) and
    :meth:`add_sensor` in arrival order; each returns the outcomes of the
    sensor samples it settled (possibly none, possibly several). Call
    :meth:`poll` from a timer so that pending samples time out even when no
    message arrives, and :meth:`summary` to publish.
    """

    def __init__(self, config: MonitorConfig) -> None:
        self.config = config
        self._counters = dict.fromkeys(COUNTER_NAMES, 0)
        self._truth_t: list[float] = []
        self._truth_roll: list[float] = []
        self._truth_pitch: list[float] = []
        self._pending: deque[PendingSample] = deque()
        self._sets = {True: StatisticsSet(), False: StatisticsSet()}
        # Ring columns: roll, pitch, meridional with the oblateness model removed, then kept.
        self._ring = OrbitRing(config.orbital_period_s, 2 * len(CHANNELS), config.harmonic_bins)
        self._settled: list[Outcome] = []
        self._stamps = {stream: StampCheck(config.clock_jump_s, config.future_tolerance_s, config.min_interval_s)
                        for stream in ("sensor", "truth", "odometry")}
        # Forward, the clock may leap as far as a sample may wait for truth before anyone need doubt it.
        self._clock = JumpDetector(config.clock_jump_s, forward_threshold_s=config.max_truth_wait_s)
        self._reset_alignment_state()

    # ----------------------------------------------------------------- state

    def _reset_alignment_state(self) -> None:
        self._truth_t.clear()
        self._truth_roll.clear()
        self._truth_pitch.clear()
        self._truth_pruned = False
        for check in self._stamps.values():
            check.reset()
        self._clock.reset()
        self._orbit = None  # (stamp_s, u_rad, inclination_rad, altitude_m, mean_motion_rad_s) from odometry
        self._ring.clear()

    def reset_alignment(self) -> list[Outcome]:
        """Start a new time axis: drop truth, pending samples (as RESET) and the harmonic ring; keep statistics."""
        outcomes = [self._skip(entry.stamp_s, Status.RESET) for entry in self._pending]
        self._pending.clear()
        self._reset_alignment_state()
        self._counters["alignment_resets"] += 1
        return outcomes

    def reset(self) -> None:
        """Forget everything: alignment, statistics and counters."""
        self._pending.clear()
        self._settled.clear()
        self._reset_alignment_state()
        for statistics in self._sets.values():
            statistics.reset()
        self._counters = dict.fromkeys(COUNTER_NAMES, 0)

    @property
    def counters(self) -> dict:
        """A copy of every counter (fixed keys: :data:`COUNTER_NAMES`)."""
        return dict(self._counters)

    @property
    def truth_buffer_length(self) -> int:
        """Truth samples held (≤ truth_capacity)."""
        return len(self._truth_t)

    @property
    def latest_truth_stamp_s(self) -> float | None:
        """Stamp of the latest accepted truth sample since the last alignment reset, s (None: none yet)."""
        return self._stamps["truth"].latest_s

    @property
    def pending_count(self) -> int:
        """Sensor samples waiting for truth (≤ max_pending)."""
        return len(self._pending)

    @property
    def ring_nbytes(self) -> int:
        """Memory of the harmonic ring, bytes (fixed)."""
        return self._ring.nbytes

    # ------------------------------------------------------------ validation

    def _observe_now(self, now_s) -> tuple[list[Outcome], float | None]:
        """Watch the node clock for jumps: (outcomes of a reset, the clock that times out waiting samples).

        While a jump of the clock is unconfirmed, waiting samples are timed
        by the old clock (a forged /clock a year ahead must not expire them);
        the future-stamp check takes the clock as it reads.
        """
        if now_s is None or not math.isfinite(now_s):
            return [], None
        now_s = float(now_s)
        verdict = self._clock.observe(now_s)
        outcomes = []
        if verdict is Jump.CONFIRMED_BACK:
            self._counters["clock_jumps"] += 1
            outcomes = self.reset_alignment()
            self._clock.observe(now_s)
        elif verdict is Jump.OUTLIER:
            self._counters["clock_outliers"] += 1
        return outcomes, self._clock.latest_s

    def _check_stamp(self, stream: str, t_s: float, now_s) -> tuple[Rejection | None, list[Outcome]]:
        """Check the stamp of a sample of ``stream`` whose values passed; a confirmed jump resets the alignment once."""
        check = self._stamps[stream]
        outliers = check.outliers
        rejection, jumped = check.check(t_s, now_s)
        self._counters["clock_outliers"] += check.outliers - outliers
        if not jumped:
            return rejection, []
        self._counters["clock_jumps"] += 1
        outcomes = self.reset_alignment()
        check.check(t_s, now_s)  # the first stamp of the new timeline
        return None, outcomes

    # ------------------------------------------------------------------ truth

    def add_truth(self, t_s: float, roll_rad: float, pitch_rad: float, *, now_s: float | None = None) -> list[Outcome]:
        """Add a truth sample (star-tracker roll, pitch in rad at stamp ``t_s`` in s).

        Args:
            now_s: the node clock now, s — enables the future-stamp check and
                clock-jump detection; None to skip both.

        Returns:
            Outcomes of the pending sensor samples this settled.
        """
        self._counters["truth_received"] += 1
        outcomes, clock_s = self._observe_now(now_s)
        t_s, roll_rad, pitch_rad = float(t_s), float(roll_rad), float(pitch_rad)
        if math.isfinite(roll_rad) and math.isfinite(pitch_rad):  # truth is complete, or it is no truth
            rejection, reset = self._check_stamp("truth", t_s, now_s)
            outcomes += reset
        else:
            rejection = Rejection.NON_FINITE
        if rejection is not None:
            self._counters[f"rejected_truth_{rejection.value}"] += 1
            return outcomes + self._expire(clock_s)
        self._truth_t.append(t_s)
        self._truth_roll.append(roll_rad)
        self._truth_pitch.append(pitch_rad)
        while self._pending and self._pending[0].stamp_s <= t_s:
            outcomes.append(self._align(self._pending.popleft()))
        outcomes += self._expire(clock_s)
        self._prune_truth()
        return outcomes

    def add_truth_quaternion(self, t_s: float, q_orbital_to_body, *, now_s: float | None = None) -> list[Outcome]:
        """Add a star-tracker quaternion (x, y, z, w), body in the orbital frame; validated, then as roll/pitch.

        The quaternion becomes the roll and pitch an ideal horizon sensor would
        read (:func:`pmv_ros.physics.attitude.true_roll_pitch`), so yaw cannot
        leak into the comparison.
        """
        q, rejection, normalised = check_quaternion(q_orbital_to_body)
        if rejection is not None:
            self._counters["truth_received"] += 1
            self._counters[f"rejected_truth_{rejection.value}"] += 1
            outcomes, clock_s = self._observe_now(now_s)
            return outcomes + self._expire(clock_s)
        if normalised:
            self._counters["truth_quaternions_normalised"] += 1
        roll, pitch = true_roll_pitch(q)
        return self.add_truth(t_s, float(roll), float(pitch), now_s=now_s)

    def _prune_truth(self) -> None:
        cutoff = self._truth_t[-1] - self.config.truth_history_s
        if self._pending:
            cutoff = min(cutoff, self._pending[0].stamp_s)
        # Keep the last sample at or before the cutoff: it brackets what comes after.
        drop = bisect.bisect_right(self._truth_t, cutoff) - 1
        drop = max(drop, len(self._truth_t) - self.config.truth_capacity)
        if drop > 0:
            del self._truth_t[:drop], self._truth_roll[:drop], self._truth_pitch[:drop]
            self._truth_pruned = True

    # ---------------------------------------------------------------- orbit

    def add_odometry(self, t_s: float, position_eci_m, velocity_eci_m_s, *,
                     now_s: float | None = None) -> Rejection | None:
        """Take the spacecraft's ECI state (m, m/s) at ``t_s`` for the oblateness model; the rejection, if any.

        A state that is not a bound Earth orbit within the bounds (|r| = 1 km,
        1e12 m, an escape speed) is rejected and counted, never used: the
        oblateness model and the ground error would be meaningless.
        """
        self._counters["odometry_received"] += 1
        outcomes, clock_s = self._observe_now(now_s)
        self._settled.extend(outcomes)
        rejection = check_orbit_state(position_eci_m, velocity_eci_m_s, self.config.bounds)
        if rejection is None:
            rejection, reset = self._check_stamp("odometry", float(t_s), now_s)
            self._settled.extend(reset)
        if rejection is not None:
            self._counters[f"rejected_odometry_{rejection.value}"] += 1
            return rejection
        self._orbit = orbit_record(float(t_s), position_eci_m, velocity_eci_m_s)
        return None

    def orbit_at(self, t_s: float, max_age_s: float) -> dict:
        """``add_sensor`` keywords (u_rad, inclination_rad, altitude_m) at ``t_s`` from the latest accepted
        odometry no further than ``max_age_s`` from it (u advanced at the mean motion); {} if there is none."""
        orbit = self._orbit
        if orbit is None or not abs(t_s - orbit[0]) <= max_age_s:
            return {}
        stamp, u, inclination, altitude, rate = orbit
        return dict(u_rad=u + rate * (t_s - stamp), inclination_rad=inclination, altitude_m=altitude)

    @property
    def latest_orbit_stamp_s(self) -> float | None:
        """Stamp of the latest accepted odometry since the last alignment reset, s (None: none yet)."""
        return None if self._orbit is None else self._orbit[0]

    @property
    def odometry_period_s(self) -> float | None:
        """The orbital period the latest accepted odometry flies (2π / mean motion), s; None without odometry."""
        return None if self._orbit is None else 2.0 * math.pi / self._orbit[4]

    def take_settled(self) -> list[Outcome]:
        """Outcomes settled by a call that returns no outcomes (an odometry message that reset the alignment)."""
        outcomes, self._settled = self._settled, []
        return outcomes

    # ----------------------------------------------------------------- sensor

    def add_sensor(self, t_s: float, roll_rad: float, pitch_rad: float, *, u_rad: float | None = None,
                   altitude_m: float | None = None, inclination_rad: float | None = None,
                   oblateness_roll_rad: float | None = None, oblateness_pitch_rad: float | None = None,
                   now_s: float | None = None) -> list[Outcome]:
        """Add a sensor sample (roll, pitch in rad at stamp ``t_s`` in s).

        The oblateness model for this sample comes from, in order: the values
        passed (``oblateness_roll_rad``/``oblateness_pitch_rad``, e.g. what the
        sensor's on-board compensation used); or the published closed form
        (physics.md §2.1) at ``u_rad`` with ``altitude_m``/``inclination_rad``
        (per sample or from the configuration). Without either, the sample
        enters only the oblateness-kept statistics (counted in
        ``used_without_oblateness_model``).

        Args:
            u_rad: argument of latitude at ``t_s``, rad (see :func:`orbit_angles_from_state`).
            altitude_m: orbit altitude at ``t_s``, m (also used for the ground error).
            inclination_rad: orbit inclination, rad.
            now_s: the node clock now, s (see :meth:`add_truth`).

        Returns:
            Outcomes settled by this call: this sample's if it was rejected or
            could be aligned at once, and any pending samples that timed out.
        """
        self._counters["sensor_received"] += 1
        outcomes, clock_s = self._observe_now(now_s)
        t_s, roll_rad, pitch_rad = float(t_s), float(roll_rad), float(pitch_rad)
        rejection = check_angles(roll_rad, pitch_rad, self.config.bounds.max_abs_angle_rad, allow_nan=True)
        if rejection is None:
            rejection, reset = self._check_stamp("sensor", t_s, now_s)
            outcomes += reset
        if rejection is not None:
            self._counters[f"rejected_sensor_{rejection.value}"] += 1
            return outcomes + [Outcome(t_s, rejection)] + self._expire(clock_s)
        if math.isnan(roll_rad) and math.isnan(pitch_rad):
            return outcomes + [self._skip(t_s, Status.NO_VALID_ANGLE)] + self._expire(clock_s)
        altitude = self.config.altitude_m if altitude_m is None else float(altitude_m)
        model_roll, model_pitch = self._oblateness(u_rad, altitude, inclination_rad,
                                                   oblateness_roll_rad, oblateness_pitch_rad)
        entry = PendingSample(t_s, roll_rad, pitch_rad, model_roll, model_pitch,
                         math.nan if altitude is None else altitude)
        if self._truth_t and self._truth_t[-1] >= t_s and not self._pending:
            outcomes.append(self._align(entry))
        else:
            self._pending.append(entry)
            if len(self._pending) > self.config.max_pending:
                outcomes.append(self._skip(self._pending.popleft().stamp_s, Status.PENDING_OVERFLOW))
        return outcomes + self._expire(clock_s)

    def _oblateness(self, u_rad, altitude, inclination_rad, model_roll, model_pitch) -> tuple[float, float]:
        if model_roll is not None and model_pitch is not None:
            return float(model_roll), float(model_pitch)
        inclination = self.config.inclination_rad if inclination_rad is None else float(inclination_rad)
        if u_rad is None or altitude is None or inclination is None:
            return math.nan, math.nan
        _, roll, pitch = closed_form_oblateness(float(u_rad), altitude, inclination)
        return float(roll), float(pitch)

    def poll(self, now_s: float | None = None) -> list[Outcome]:
        """Time out pending samples by the clock (call from a timer); returns their outcomes."""
        outcomes, clock_s = self._observe_now(now_s)
        return self.take_settled() + outcomes + self._expire(clock_s)

    def _expire(self, now_s) -> list[Outcome]:
        """Give up pending samples that have waited longer than max_truth_wait_s."""
        latest = self._stamps["sensor"].latest_s
        if now_s is not None and math.isfinite(now_s):
            latest = now_s if latest is None else max(latest, now_s)
        outcomes = []
        while self._pending and latest is not None and latest - self._pending[0].stamp_s > self.config.max_truth_wait_s:
            outcomes.append(self._skip(self._pending.popleft().stamp_s, Status.STALE_TRUTH))
        return outcomes

    # -------------------------------------------------------------- alignment

    def _skip(self, t_s: float, status: Status) -> Outcome:
        self._counters[f"skipped_{status.value}"] += 1
        return Outcome(t_s, status)

    def _align(self, entry: PendingSample) -> Outcome:
        """Interpolate truth at the sample's stamp and account the residual, or say why not."""
        times = self._truth_t
        t = entry.stamp_s
        after = bisect.bisect_left(times, t)
        if after < len(times) and times[after] == t:
            truth_roll, truth_pitch = self._truth_roll[after], self._truth_pitch[after]
        elif after == 0:
            return self._skip(t, Status.TOO_OLD if self._truth_pruned else Status.NO_TRUTH)
        else:
            before = after - 1
            span = times[after] - times[before]
            if span > self.config.max_truth_gap_s:
                return self._skip(t, Status.TRUTH_GAP)
            weight = (t - times[before]) / span
            truth_roll = self._truth_roll[before] + weight * (self._truth_roll[after] - self._truth_roll[before])
            truth_pitch = self._truth_pitch[before] + weight * (self._truth_pitch[after] - self._truth_pitch[before])
        return self._account(entry, entry.roll_rad - truth_roll, entry.pitch_rad - truth_pitch)

    def _account(self, entry: PendingSample, residual_roll: float, residual_pitch: float) -> Outcome:
        """Update both statistics sets and the ring with one residual; return the outcome.

        Runs once per sensor sample: plain floats, straight-line code.
        """
        counters = self._counters
        counters["used"] += 1
        if math.isnan(residual_roll) or math.isnan(residual_pitch):
            # One chord pair lost: the other angle counts; the meridional value does not exist.
            counters["used_one_angle"] += 1
        roll_kept = residual_roll - self.config.roll_offset_rad
        pitch_kept = residual_pitch - self.config.pitch_offset_rad
        kept = (roll_kept, pitch_kept, math.hypot(roll_kept, pitch_kept))
        has_model = math.isfinite(entry.oblateness_roll_rad) and math.isfinite(entry.oblateness_pitch_rad)
        if has_model:
            roll_removed = roll_kept - entry.oblateness_roll_rad
            pitch_removed = pitch_kept - entry.oblateness_pitch_rad
            removed = (roll_removed, pitch_removed, math.hypot(roll_removed, pitch_removed))
        else:
            counters["used_without_oblateness_model"] += 1
            removed = (math.nan, math.nan, math.nan)
        with_ground = math.isfinite(entry.altitude_m) and entry.altitude_m > 0.0
        grounds = {}
        for key, row in ((False, kept), (True, removed)):
            if key and not has_model:
                continue
            target = self._sets[key]
            for stats, value in zip(target.angles, row):
                if math.isfinite(value):
                    stats.add(value)
            if with_ground:
                ground = grounds[key] = ground_components(row, entry.altitude_m)
                for stats, value in zip(target.ground, ground):
                    if math.isfinite(value):
                        stats.add(value)
        self._ring.add(entry.stamp_s, removed + kept)
        primary = self.config.remove_oblateness
        cross, along, circular = grounds.get(primary, (math.nan, math.nan, math.nan))
        return Outcome(entry.stamp_s, Status.OK, residual_roll, residual_pitch, *(removed if primary else kept),
                       along_track_m=along, cross_track_m=cross, circular_m=circular)

    # ---------------------------------------------------------------- summary

    def summary(self, oblateness_removed: bool | None = None) -> MonitorSummary:
        """The statistics for publication (default: the configured oblateness choice) and the counters.

        Harmonic amplitudes are fitted here (a few ms for the default ring),
        so call it at the publication rate, not per sample.
        """
        removed = self.config.remove_oblateness if oblateness_removed is None else bool(oblateness_removed)
        amplitudes = self._ring.amplitudes(self.config.harmonics,
                                           max_gap_fraction=self.config.max_harmonic_gap_fraction,
                                           max_condition=DEFAULT_MAX_CONDITION)
        first_column = 0 if removed else len(CHANNELS)
        channels = []
        for index, name in enumerate(CHANNELS):
            angle = self._sets[removed].angles[index]
            ground = self._sets[removed].ground[index]
            harmonics = {int(k): float(a) for k, a in zip(self.config.harmonics, amplitudes[:, first_column + index])}
            channels.append(ChannelStatistics(name, angle.count, angle.mean, angle.sigma, angle.max_abs, harmonics,
                                               ground.mean, ground.sigma, ground.max_abs))
        return MonitorSummary(removed, tuple(channels), self.counters, self._ring.full_orbit)
