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

Validation (issues 6 and 15; the checks are :mod:`pmv_ros.runtime.common.validation`)
    Every incoming sample is checked before it touches any state: non-finite
    values, a zero (unset) or negative stamp, a stamp in the future of
    ``now_s``, a duplicate or backwards stamp, one stamped faster than the
    stream may be (``min_interval_s``), a quaternion far from unit norm
    (near-unit ones are normalised and counted), a sensor angle beyond the
    plausibility bound, an orbit state that is not a bound Earth orbit. So no
    statistic can become non-finite: every value that reaches one is finite
    and bounded.

Clock jumps (the rule of :class:`~pmv_ros.runtime.common.validation.JumpDetector`)
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

One path
    Every input is a batch: one message is a batch of one event
    (:meth:`add_sensor`, :meth:`add_truth_quaternion`, :meth:`add_odometry`,
    :meth:`poll`), a campaign's flight a batch of an orbit
    (:meth:`add_batch`). The inputs are validated in arrival order, into an
    open segment (:mod:`pmv_ros.runtime.monitor.scan`; on arrays when a batch
    is clean); a segment — never across a clock jump — is aligned on arrays
    (:mod:`pmv_ros.runtime.monitor.alignment`), a node's message of one sample
    as a campaign's orbit, at the end of the input that makes anything in it
    settle, and the used samples enter the
    statistics when these are read (:meth:`summary`). How the same events are cut into
    batches changes nothing but the order in which sums are taken (≈ 1e-15
    relative).

Not thread-safe: call it from one executor thread.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable

import numpy as np

from ...analysis.statistics import CHANNELS, ChannelStatistics, OrbitRing, update_rows
from .alignment import Alignment, Segment, Settled
from .records import (
    BATCH_STATUSES,
    COUNTER_NAMES,
    SENSOR_REJECTIONS,
    SKIP_REASONS,
    BatchOutcome,
    Feed,
    MonitorConfig,
    MonitorSummary,
    Outcome,
    StatisticsSet,
    Status,
    ground_components,
)
from .scan import MIN_ARRAY_SAMPLES, EventScan, OpenSegment, scan_clean
from ..common.validation import MAX_PLAUSIBLE_RESIDUAL_RAD, JumpDetector, Rejection, StampCheck

_SKIP_CODES = {BATCH_STATUSES.index(status): f"skipped_{status.value}" for status in SKIP_REASONS}
_OK = BATCH_STATUSES.index(Status.OK)
_IMPLAUSIBLE_RESIDUAL = BATCH_STATUSES.index(Status.IMPLAUSIBLE_RESIDUAL)
_FIRST_REFUSAL = BATCH_STATUSES.index(SENSOR_REJECTIONS[0])  # codes from here on: refused on arrival
_FIRST = (0,)  # the arrival of the one truth or odometry sample of a one-event input

#: Used samples kept for the statistics before they go in whether or not anyone reads them (memory bound).
UNACCOUNTED_ROWS = 4096


def _column(value, n: int, default=math.nan) -> np.ndarray:
    """A per-sample argument (an array, one value for all, None for ``default``) as ``(n,)`` floats."""
    return np.broadcast_to(np.asarray(default if value is None else value, float), (n,))


def _one(value) -> list:
    """One value of a one-event input (None: NaN)."""
    return [math.nan if value is None else float(value)]


class ErrorMonitor(EventScan):
    """Align sensor roll/pitch with star-tracker truth and keep live error statistics (physics.md §5, §5.1, §6, §7).

    Feed it with :meth:`add_truth` (or :meth:`add_truth_quaternion`), :meth:`add_odometry` and
    :meth:`add_sensor` in arrival order, or with a whole stretch at once (:meth:`add_batch`); each returns
    the outcomes of the sensor samples it settled (possibly none, possibly several). Call :meth:`poll`
    from a timer so that pending samples time out even when no message arrives, and :meth:`summary` to
    publish.
    """

    def __init__(self, config: MonitorConfig) -> None:
        self.config = config
        self._counters = dict.fromkeys(COUNTER_NAMES, 0)
        self._sets = {True: StatisticsSet(), False: StatisticsSet()}
        # Ring columns: roll, pitch, meridional with the oblateness model removed, then kept.
        self._ring = OrbitRing(config.orbital_period_s, 2 * len(CHANNELS), config.harmonic_bins)
        self._alignment = Alignment(config)
        self._stamps = {stream: StampCheck(config.clock_jump_s, config.future_tolerance_s, config.min_interval_s)
                        for stream in ("sensor", "truth", "odometry")}
        # Forward, the clock may leap as far as a sample may wait for truth before anyone need doubt it.
        self._clock = JumpDetector(config.clock_jump_s, forward_threshold_s=config.max_truth_wait_s)
        self._orbit = None  # orbit_record of the latest accepted odometry since the last reset
        self._later: list[Settled] = []  # settled by an odometry message: handed out by take_settled / poll
        self._odometry_rejection = None
        self._open = OpenSegment()
        self._serial = 0  # inputs so far: a sample's index means something in its own input only
        self._parts: list[Settled] = []  # what the current input settled so far
        self._unaccounted: list = []  # used samples not in the statistics yet: (stamps, angles (6, n), altitude)
        self._unaccounted_count = 0

    # ----------------------------------------------------------------- state

    def _reset_alignment_state(self) -> None:
        self._account_statistics()  # the ring is cleared below: what it has not had yet goes in first
        self._alignment.clear()
        for check in self._stamps.values():
            check.reset()
        self._clock.reset()
        self._orbit = None
        self._ring.clear()

    def _reset(self) -> None:
        """A new time axis: what came before is settled, then the samples still waiting settle as RESET;
        truth, the ring and the timelines are dropped."""
        self._settle_open()
        self._parts.append(self._account(self._alignment.take_pending()))
        self._reset_alignment_state()
        self._open = OpenSegment()
        self._counters["alignment_resets"] += 1

    def reset_alignment(self) -> list[Outcome]:
        """Start a new time axis: drop truth, pending samples (as RESET) and the harmonic ring; keep statistics."""
        self._parts = []
        self._reset()
        parts, self._parts = self._parts, []
        return self._outcomes(Settled.concatenate(parts))

    def new_epoch(self) -> None:
        """A source restarted its timeline: statistics and the harmonic ring start over; alignment and counters
        carry on. Samples not yet in the statistics belong to the old epoch and are dropped with it."""
        self._unaccounted, self._unaccounted_count = [], 0
        for statistics in self._sets.values():
            statistics.reset()
        self._ring.clear()

    def reset(self) -> None:
        """Forget everything: alignment, statistics and counters."""
        self._alignment.clear()
        self._later.clear()
        self._open = OpenSegment()
        self._unaccounted, self._unaccounted_count = [], 0
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
        return self._alignment.truth_count

    @property
    def timelines(self) -> dict:
        """The latest time of each timeline the monitor keeps since the last alignment reset, s (None: none yet):
        ``clock`` (the node clock), ``sensor``, ``truth``, ``odometry`` (the accepted stamps of each input)."""
        return {"clock": self._clock.latest_s, **{stream: check.latest_s for stream, check in self._stamps.items()}}

    @property
    def latest_truth_stamp_s(self) -> float | None:
        """Stamp of the latest accepted truth sample since the last alignment reset, s (None: none yet)."""
        return self._stamps["truth"].latest_s

    @property
    def pending_count(self) -> int:
        """Sensor samples waiting for truth (≤ max_pending)."""
        return self._alignment.pending_count + self._open.waiting

    @property
    def ring_nbytes(self) -> int:
        """Memory of the harmonic ring, bytes (fixed)."""
        return self._ring.nbytes

    @property
    def latest_orbit_stamp_s(self) -> float | None:
        """Stamp of the latest accepted odometry since the last alignment reset, s (None: none yet)."""
        return None if self._orbit is None else self._orbit[0]

    @property
    def odometry_period_s(self) -> float | None:
        """The orbital period the latest accepted odometry flies (2π / mean motion), s; None without odometry."""
        return None if self._orbit is None else 2.0 * math.pi / self._orbit[4]

    def orbit_at(self, t_s: float, max_age_s: float) -> dict:
        """``add_sensor`` keywords (u_rad, inclination_rad, altitude_m) at ``t_s`` from the latest accepted
        odometry no further than ``max_age_s`` from it (u advanced at the mean motion); {} if there is none."""
        orbit = self._orbit
        if orbit is None or not abs(t_s - orbit[0]) <= max_age_s:
            return {}
        stamp, u, inclination, altitude, rate = orbit
        return dict(u_rad=u + rate * (t_s - stamp), inclination_rad=inclination, altitude_m=altitude)

    # ------------------------------------------------------------------ inputs

    def add_truth(self, t_s: float, roll_rad: float, pitch_rad: float, *, now_s: float | None = None) -> list[Outcome]:
        """Add a truth sample (star-tracker roll, pitch in rad at stamp ``t_s`` in s).

        Args:
            now_s: the node clock now, s — enables the future-stamp check and
                clock-jump detection; None to skip both.

        Returns:
            Outcomes of the pending sensor samples this settled.
        """
        return self._truth_input(t_s, np.array([[float(roll_rad)], [float(pitch_rad)]]), now_s)

    def add_truth_quaternion(self, t_s: float, q_orbital_to_body, *, now_s: float | None = None) -> list[Outcome]:
        """Add a star-tracker quaternion (x, y, z, w), body in the orbital frame; validated, then as roll/pitch.

        The quaternion becomes the roll and pitch an ideal horizon sensor would
        read (:func:`pmv_ros.physics.attitude.true_roll_pitch`), so yaw cannot
        leak into the comparison.
        """
        try:
            q = np.asarray(q_orbital_to_body, float).reshape(4, 1)
        except (TypeError, ValueError):
            q = np.full((4, 1), math.nan)  # not four numbers: rejected as non-finite
        return self._truth_input(t_s, q, now_s)

    def _truth_input(self, t_s, truth: np.ndarray, now_s) -> list[Outcome]:
        feed = Feed((), (), (), truth_t_s=_one(t_s), truth=truth, truth_arrival=_FIRST,
                    truth_now_s=None if now_s is None else _one(now_s))
        return self._outcomes(self._feed(feed))

    def add_odometry(self, t_s: float, position_eci_m, velocity_eci_m_s, *,
                     now_s: float | None = None) -> Rejection | None:
        """Take the spacecraft's ECI state (m, m/s) at ``t_s`` for the oblateness model; the rejection, if any.

        A state that is not a bound Earth orbit within the bounds (|r| = 1 km,
        1e12 m, an escape speed) is rejected and counted, never used: the
        oblateness model and the ground error would be meaningless. Samples it
        settles (a clock jump's reset) come from :meth:`take_settled`.
        """
        try:
            position = np.asarray(position_eci_m, float).reshape(3, 1)
            velocity = np.asarray(velocity_eci_m_s, float).reshape(3, 1)
        except (TypeError, ValueError):
            position = velocity = np.full((3, 1), math.nan)  # not a state: rejected as implausible
        feed = Feed((), (), (), odometry_t_s=_one(t_s), odometry_position_m=position,
                    odometry_velocity_m_s=velocity, odometry_arrival=_FIRST,
                    odometry_now_s=None if now_s is None else _one(now_s))
        settled = self._feed(feed)
        if settled.size:  # nothing is kept for take_settled unless something settled
            self._later.append(settled)
        return self._odometry_rejection

    def take_settled(self) -> list[Outcome]:
        """Outcomes settled by a call that returns no outcomes (an odometry message that reset the alignment)."""
        if not self._later:
            return []
        later, self._later = self._later, []
        return self._outcomes(Settled.concatenate(later))

    def add_sensor(self, t_s: float, roll_rad: float, pitch_rad: float, *, u_rad: float | None = None,
                   altitude_m: float | None = None, inclination_rad: float | None = None,
                   oblateness_roll_rad: float | None = None, oblateness_pitch_rad: float | None = None,
                   odometry_max_age_s: float | None = None, now_s: float | None = None) -> list[Outcome]:
        """Add a sensor sample (roll, pitch in rad at stamp ``t_s`` in s).

        The oblateness model for this sample comes from, in order: the values
        passed (``oblateness_roll_rad``/``oblateness_pitch_rad``, e.g. what the
        sensor's on-board compensation used); or the published closed form
        (physics.md §2.1) at the orbit — that of the latest odometry no further
        than ``odometry_max_age_s`` from the stamp when that is given, else
        ``u_rad`` with ``altitude_m``/``inclination_rad`` (per sample or from
        the configuration). Without either, the sample enters only the
        oblateness-kept statistics (counted in ``used_without_oblateness_model``).

        Args:
            u_rad: argument of latitude at ``t_s``, rad (see :func:`orbit_angles_from_state`).
            altitude_m: orbit altitude at ``t_s``, m (also used for the ground error).
            inclination_rad: orbit inclination, rad.
            now_s: the node clock now, s (see :meth:`add_truth`).

        Returns:
            Outcomes settled by this call: this sample's if it was rejected or
            could be aligned at once, and any pending samples that timed out.
        """
        config = self.config
        given = oblateness_roll_rad is not None and oblateness_pitch_rad is not None
        feed = Feed(_one(t_s), _one(roll_rad), _one(pitch_rad), None if now_s is None else _one(now_s),
                    odometry_max_age_s=odometry_max_age_s, u_rad=_one(u_rad),
                    inclination_rad=_one(config.inclination_rad if inclination_rad is None else inclination_rad),
                    altitude_m=_one(config.altitude_m if altitude_m is None else altitude_m),
                    model_roll_rad=_one(oblateness_roll_rad) if given else None,
                    model_pitch_rad=_one(oblateness_pitch_rad) if given else None)
        return self._outcomes(self._feed(feed))

    def add_inputs(self, feed: Feed, place: int | None = None) -> tuple[list[Outcome], bool]:
        """Any input in arrival order (a :class:`Feed`; a node's messages with their ``order``): the outcomes it
        settled, in order, and whether its sensor sample at ``place`` was refused on arrival (False: no place)."""
        settled = self._feed(feed)
        outcomes = self.take_settled() + self._outcomes(settled)
        if place is None or not settled.size:
            return outcomes, False
        refused = (settled.values[0] == place) & (settled.values[2] >= _FIRST_REFUSAL)
        return outcomes, bool(refused.any())

    def poll(self, now_s: float | None = None) -> list[Outcome]:
        """Time out pending samples by the clock (call from a timer); returns their outcomes."""
        later = self.take_settled()
        return later + self._outcomes(self._feed(Feed((), (), (), poll_now_s=math.nan if now_s is None
                                                      else float(now_s))))

    def add_batch(self, sensor_t_s, sensor_roll_rad, sensor_pitch_rad, truth_t_s, q_truth, truth_arrival, *,
                  now_s=None, odometry=None, odometry_max_age_s: float = math.inf, u_rad=None,
                  altitude_m: float | None = None, inclination_rad: float | None = None,
                  oblateness_roll_rad=None, oblateness_pitch_rad=None) -> BatchOutcome:
        """Many samples at once: what :meth:`add_truth_quaternion`, :meth:`add_odometry` and :meth:`add_sensor`,
        called in arrival order, would do — the same code, on arrays.

        Arrival order, per sensor sample i: the truth samples with ``truth_arrival == i``, then the
        odometry at the sample's stamp (if given), then the sample.

        Args:
            sensor_t_s, sensor_roll_rad, sensor_pitch_rad: ``(N,)`` sensor samples (s, rad), in arrival order.
            truth_t_s: ``(M,)`` truth stamps, s, in arrival order; ``q_truth``: ``(4, M)`` quaternions (x, y, z, w).
            truth_arrival: ``(M,)`` non-decreasing ints: truth j arrives just before sensor sample
                ``truth_arrival[j]`` (N: after the last one).
            now_s: ``(N,)`` node clock when each sensor sample arrives (a truth arriving before sample i
                sees ``now_s[i]``; after the last, ``now_s[-1]``), s; None: no clock (see :meth:`add_truth`).
            odometry: ``(position_eci_m, velocity_eci_m_s)``, each ``(3, N)``: the spacecraft's state at each
                sensor stamp (what /orbit/odometry carries), for the oblateness model and the ground error
                as the node takes them (the latest no further than ``odometry_max_age_s``); None: the
                ``u_rad``/``altitude_m``/``inclination_rad`` of :meth:`add_sensor` instead
                (``u_rad`` ``(N,)``, the others scalars).
            oblateness_roll_rad, oblateness_pitch_rad: the model itself, ``(N,)`` or scalars, as in
                :meth:`add_sensor` (e.g. zeros when the sensor removes it on board).

        Returns:
            :class:`BatchOutcome`: per sensor sample, the status code and the residuals; samples of earlier
            inputs settled by this one in ``earlier``.
        """
        feed = self.batch_feed(sensor_t_s, sensor_roll_rad, sensor_pitch_rad, truth_t_s, q_truth, truth_arrival,
                                now_s=now_s, odometry=odometry, odometry_max_age_s=odometry_max_age_s, u_rad=u_rad,
                                altitude_m=altitude_m, inclination_rad=inclination_rad,
                                oblateness_roll_rad=oblateness_roll_rad, oblateness_pitch_rad=oblateness_pitch_rad)
        n = len(feed.t_s)
        settled = self._feed(feed)
        result = BatchOutcome.empty(n)
        index = settled.index
        mine = index >= 0
        rows = index[mine]
        result.status[rows] = settled.code[mine]
        for name in ("residual_roll_rad", "residual_pitch_rad", "roll_rad", "pitch_rad", "meridional_rad"):
            getattr(result, name)[rows] = settled.row(name)[mine]
        result.earlier = self._outcomes(settled.take(~mine))
        return result

    def batch_feed(self, sensor_t_s, sensor_roll_rad, sensor_pitch_rad, truth_t_s, q_truth, truth_arrival, *,
                    now_s=None, odometry=None, odometry_max_age_s: float = math.inf, u_rad=None,
                    altitude_m: float | None = None, inclination_rad: float | None = None,
                    oblateness_roll_rad=None, oblateness_pitch_rad=None) -> Feed:
        """The :class:`Feed` an :meth:`add_batch` call with these arguments makes (ValueError for arrivals out of
        order): what :meth:`add_inputs` takes."""
        t = np.asarray(sensor_t_s, float).ravel()
        n = t.size
        truth_t = np.asarray(truth_t_s, float).ravel()
        arrival = np.asarray(truth_arrival, np.int64).ravel()
        if arrival.size != truth_t.size or (arrival.size and (np.any(np.diff(arrival) < 0) or arrival[0] < 0
                                                              or arrival[-1] > n)):
            raise ValueError("truth_arrival must give, for each truth sample, a non-decreasing sensor index 0 … N")
        now = None if now_s is None else _column(now_s, n)
        given = oblateness_roll_rad is not None and oblateness_pitch_rad is not None
        config = self.config
        feed = Feed(t, _column(sensor_roll_rad, n), _column(sensor_pitch_rad, n), now, truth_t_s=truth_t,
                    truth=np.asarray(q_truth, float).reshape(4, truth_t.size), truth_arrival=arrival,
                    truth_now_s=None if now is None or not n else now[np.minimum(arrival, n - 1)],
                    model_roll_rad=_column(oblateness_roll_rad, n) if given else None,
                    model_pitch_rad=_column(oblateness_pitch_rad, n) if given else None)
        if odometry is not None:
            feed.odometry_t_s, feed.odometry_arrival, feed.odometry_now_s = t, np.arange(n), now
            feed.odometry_position_m, feed.odometry_velocity_m_s = (np.asarray(part, float).reshape(3, n)
                                                                    for part in odometry)
            feed.odometry_max_age_s = float(odometry_max_age_s)
        else:
            feed.u_rad = _column(u_rad, n)
            feed.inclination_rad = _column(config.inclination_rad if inclination_rad is None else inclination_rad, n)
            feed.altitude_m = _column(config.altitude_m if altitude_m is None else altitude_m, n)
        return feed

    # ------------------------------------------------------------ the one path

    def _feed(self, feed: Feed) -> Settled:
        """Validate, align and account one input; what it settled, in order (``index`` −1: earlier inputs)."""
        self._serial += 1
        self._parts = []
        segment = None
        if len(feed.t_s) >= MIN_ARRAY_SAMPLES:
            self._settle_open()  # what came before goes first
            segment = scan_clean(self, feed)
        if segment is not None:
            self._parts.append(self._settle(segment))
        else:
            self._scan_events(feed)
            if self._open.due:
                self._settle_open()
        self._alignment.forget_indices()
        parts, self._parts = self._parts, []
        return Settled.concatenate(parts)

    def _settle_open(self) -> None:
        """Settle the open segment (its results go with the current input) and open a new one."""
        gathered = self._open
        if gathered.expiry:
            self._parts.append(self._settle(self._segment(gathered)))
        elif self._open.truth or self._open.sensor:
            raise RuntimeError("monitor: samples gathered without an event")
        self._open = OpenSegment()

    def _settle(self, segment: Segment) -> Settled:
        return self._account(self._alignment.settle(segment))

    # -------------------------------------------------------------- statistics

    def _account(self, settled: Settled) -> Settled:
        """Count what settled; give the used samples their reported values and keep them for the statistics."""
        if not settled.size:
            return settled
        counters = self._counters
        ok = settled.values[2] == _OK
        with np.errstate(invalid="ignore"):  # NaN: a lost chord pair, not a residual
            implausible = ok & ((np.abs(settled.values[3]) > MAX_PLAUSIBLE_RESIDUAL_RAD)
                                | (np.abs(settled.values[4]) > MAX_PLAUSIBLE_RESIDUAL_RAD))
        if implausible.any():
            settled.values[2, implausible] = _IMPLAUSIBLE_RESIDUAL
            ok &= ~implausible
        used = int(np.count_nonzero(ok))
        if used < settled.size:  # skipped or refused samples among them: counted per reason
            codes = np.bincount(settled.code, minlength=len(BATCH_STATUSES)).tolist()
            for status, count in enumerate(codes):
                if count and status in _SKIP_CODES:
                    counters[_SKIP_CODES[status]] += count
            if not used:
                return settled
        rows = ok if used < settled.size else slice(None)
        config = self.config
        _, t, _, residual_roll, residual_pitch, model_roll, model_pitch, altitude = settled.values[:, rows]
        counters["used"] += used
        counters["used_one_angle"] += int(np.count_nonzero(np.isnan(residual_roll) | np.isnan(residual_pitch)))
        has_model = np.isfinite(model_roll) & np.isfinite(model_pitch)
        counters["used_without_oblateness_model"] += used - int(np.count_nonzero(has_model))
        # Rows: roll, pitch, meridional with the oblateness model kept, then removed (NaN without a model).
        angles = np.empty((6, used))
        angles[0] = residual_roll - config.roll_offset_rad
        angles[1] = residual_pitch - config.pitch_offset_rad
        angles[3] = np.where(has_model, angles[0] - model_roll, np.nan)
        angles[4] = np.where(has_model, angles[1] - model_pitch, np.nan)
        angles[2], angles[5] = np.hypot(angles[0], angles[1]), np.hypot(angles[3], angles[4])
        return self._keep(settled, rows, t, angles, altitude)

    def _keep(self, settled: Settled, rows, t, angles: np.ndarray, altitude) -> Settled:
        """Give the used samples (``rows`` of ``settled``) their reported values and keep them for the statistics:
        ``angles`` (6, used) rows roll, pitch, meridional with the oblateness model kept, then removed."""
        first = 3 if self.config.remove_oblateness else 0
        if angles.shape[1] < settled.size:
            settled.report()[:, rows] = angles[first:first + 3]
        else:
            settled.reported = angles[first:first + 3].copy()
        self._unaccounted.append((t, angles, altitude))
        self._unaccounted_count += angles.shape[1]
        if self._unaccounted_count >= UNACCOUNTED_ROWS:
            self._account_statistics()
        return settled

    def _account_statistics(self) -> None:
        """Put the used samples kept so far into both statistics sets (angles and ground error) and the ring.

        The statistics are read at the publication rate, not per sample: a few samples at a time go in one by
        one, many as a batch (the sums differ only by rounding), and the ground error is computed once for all.
        """
        if not self._unaccounted:
            return
        parts, self._unaccounted, self._unaccounted_count = self._unaccounted, [], 0
        t = np.concatenate([part[0] for part in parts])
        angles = np.concatenate([part[1] for part in parts], axis=1)
        altitude = np.concatenate([part[2] for part in parts])
        n = t.size
        ground = np.vstack(ground_components((np.concatenate((angles[0], angles[3])),
                                              np.concatenate((angles[1], angles[4])),
                                              np.concatenate((angles[2], angles[5]))),
                                             np.concatenate((altitude, altitude))))
        kept_set, removed_set = self._sets[False], self._sets[True]
        update_rows(kept_set.angles + removed_set.angles + kept_set.ground + removed_set.ground,
                    np.vstack((angles, ground[:, :n], ground[:, n:])))
        self._ring.add_many(t, np.vstack((angles[3:], angles[:3])).T)  # ring columns: removed, then kept

    @staticmethod
    def _outcomes(settled: Settled) -> list[Outcome]:
        """The settled samples as :class:`Outcome` items, in order."""
        if not settled.size:
            return []
        return [Outcome(t, BATCH_STATUSES[int(code)], residual_roll, residual_pitch, roll, pitch, meridional,
                        altitude)
                for (_, t, code, residual_roll, residual_pitch, _, _, altitude), (roll, pitch, meridional)
                in zip(settled.rows(), settled.report().T.tolist())]

    # ---------------------------------------------------------------- summary

    def summary(self, oblateness_removed: bool | None = None) -> MonitorSummary:
        """The statistics for publication (default: the configured oblateness choice) and the counters.

        Harmonic amplitudes are fitted here (≈ 1 ms once the ring holds an orbit),
        so call it at the publication rate, not per sample.
        """
        return self.summary_later(oblateness_removed)()

    def summary_later(self, oblateness_removed: bool | None = None) -> Callable[[], MonitorSummary]:
        """:meth:`summary` as of now, made when the returned function is called: the samples are accounted, the
        statistics and counters read and the ring's bins copied now; the harmonic fit waits for the call
        (:meth:`~pmv_ros.analysis.statistics.OrbitRing.amplitudes_later`). The same summary, bit for bit."""
        self._account_statistics()
        removed = self.config.remove_oblateness if oblateness_removed is None else bool(oblateness_removed)
        fits = self._ring.fits_later(self.config.harmonics, max_noise_gain=self.config.max_harmonic_noise_gain)
        first_column = 0 if removed else len(CHANNELS)
        sets = self._sets[removed]
        channels = [ChannelStatistics(name, angle.count, angle.mean, angle.sigma, angle.max_abs, {}, ground.mean,
                                      ground.sigma, ground.max_abs)
                    for name, angle, ground in zip(CHANNELS, sets.angles, sets.ground)]
        counters, full_orbit, harmonics = self.counters, self._ring.full_orbit, tuple(self.config.harmonics)

        def summary() -> MonitorSummary:
            fitted = fits()[first_column:first_column + len(CHANNELS)]
            return MonitorSummary(removed, tuple(
                replace(channel, harmonics_rad={k: math.nan if fit is None else float(a) for k, a in
                                                zip(harmonics, np.full(len(harmonics), np.nan) if fit is None
                                                    else fit.amplitude)},
                        harmonics_pending=("no full orbit of samples yet" if not full_orbit else
                                           "no sample in the last orbit") if fit is None else fit.pending_note)
                for channel, fit in zip(channels, fitted)), counters, full_orbit)

        return summary

