"""The error monitor fed many samples at once: the same validation, alignment and statistics on arrays.

:class:`BatchFeeding` gives :class:`pmv_ros.runtime.monitor.ErrorMonitor` its
``add_batch``: what ``add_truth_quaternion``, ``add_odometry`` and
``add_sensor`` called in arrival order would do. The inputs are checked on
arrays when the batch is clean (every stamp on its timeline, the clock
steady: :meth:`BatchFeeding._scan_clean_batch`), else one by one
(:meth:`BatchFeeding._scan_batch`); the alignment and the statistics then
run on arrays. A batch the array form cannot follow exactly (a clock jump,
samples already pending, …) is fed sample by sample instead.
"""


from __future__ import annotations

import copy
import math

import numpy as np

from ..physics.attitude import true_roll_pitch
from ..physics.constants import GM_EARTH_M3_S2
from ..physics.ground_error import nadir_ground_error
from ..physics.oblateness import closed_form_oblateness
from ..physics.orbit import orbit_angles_from_state
from .validation import (
    QUATERNION_NORM_TOLERANCE,
    UNIT_ROUNDING,
    Jump,
    Rejection,
    check_angles,
    check_orbit_state,
    check_quaternion,
)


from .monitor_records import BATCH_STATUSES, COUNTER_NAMES, PENDING_CODE, BatchOutcome, PendingSample, Status


#: ``math.hypot`` of four arrays, element by element: the norm check_quaternion takes (numpy's hypot has two
#: arguments and rounds otherwise).
_HYPOT_4 = np.frompyfunc(math.hypot, 4, 1)


def _element(value, index: int):
    """Element ``index`` of a per-sample argument (an array, a scalar for all, or None) as a float or None."""
    if value is None:
        return None
    array = np.asarray(value, float)
    return float(array) if array.ndim == 0 else float(array[index])


def _first_expired(clocks: np.ndarray, stamp: np.ndarray, wait_s: float) -> np.ndarray:
    """Per stamp, the first index of the non-decreasing ``clocks`` with ``clock − stamp > wait_s`` in floats —
    the test of ErrorMonitor._expire (a search on ``stamp + wait_s`` alone can be one value off by rounding)."""
    size = clocks.size
    first = np.searchsorted(clocks, stamp + wait_s, side="right")
    before = np.maximum(first - 1, 0)
    back = (first > 0) & (clocks[before] - stamp > wait_s) if size else np.zeros(stamp.shape, bool)
    first = np.where(back, np.searchsorted(clocks, clocks[before] if size else stamp, side="left"), first)
    at = np.minimum(first, max(size - 1, 0))
    on = (first < size) & ~(clocks[at] - stamp > wait_s) if size else np.zeros(stamp.shape, bool)
    return np.where(on, np.searchsorted(clocks, clocks[at] if size else stamp, side="right"), first)


def _ground_arrays(columns, altitude_m: float):
    """(cross-track, along-track, circular) ground errors, m, of (roll, pitch, meridional) residual arrays, as
    :func:`ground_components` gives them row by row."""
    roll, pitch, meridional = columns
    error = nadir_ground_error(np.where(np.isnan(roll), 0.0, roll), np.where(np.isnan(pitch), 0.0, pitch), altitude_m)
    return (np.where(np.isnan(roll), np.nan, error.cross_track_m),
            np.where(np.isnan(pitch), np.nan, error.along_track_m),
            np.where(np.isnan(meridional), np.nan, error.circular_m))


def _orbit_records(t_s: np.ndarray, position_eci_m: np.ndarray, velocity_eci_m_s: np.ndarray) -> np.ndarray:
    """:func:`orbit_record` of ``(N,)`` stamps and ``(3, N)`` states: ``(5, N)``."""
    if not t_s.size:
        return np.empty((5, 0))
    u, inclination, altitude = orbit_angles_from_state(position_eci_m, velocity_eci_m_s)
    rate = np.linalg.norm(velocity_eci_m_s, axis=0) / np.linalg.norm(position_eci_m, axis=0)
    return np.vstack([t_s, u, inclination, altitude, rate])


class BatchFeeding:
    """``add_batch`` and its array path, mixed into :class:`pmv_ros.runtime.monitor.ErrorMonitor`."""

    def add_batch(self, sensor_t_s, sensor_roll_rad, sensor_pitch_rad, truth_t_s, q_truth, truth_arrival, *,
                  now_s=None, odometry=None, odometry_max_age_s: float = math.inf, u_rad=None,
                  altitude_m: float | None = None, inclination_rad: float | None = None,
                  oblateness_roll_rad=None, oblateness_pitch_rad=None) -> "BatchOutcome":
        """Many samples at once: what :meth:`add_truth_quaternion`, :meth:`add_odometry` and :meth:`add_sensor`,
        called in arrival order, would do — the same validation, alignment and statistics.

        Each input goes through the same checks (:mod:`pmv_ros.runtime.validation`) one by one, in
        arrival order; the alignment and the statistics then run on arrays. A batch the array form
        cannot follow exactly — a clock jump or outlier, samples already pending, truth that the
        history or the capacity would prune before use, a pending queue that would overflow — is fed
        sample by sample instead, so the result is always the per-sample one (up to the order of
        summation, ≈ 1e-15 relative).

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
                as the node takes them (:meth:`orbit_at` with ``odometry_max_age_s``); None: the
                ``u_rad``/``altitude_m``/``inclination_rad`` of :meth:`add_sensor` instead
                (``u_rad`` ``(N,)``, the others scalars).
            oblateness_roll_rad, oblateness_pitch_rad: the model itself, ``(N,)`` or scalars, as in
                :meth:`add_sensor` (e.g. zeros when the sensor removes it on board).

        Returns:
            :class:`BatchOutcome`: per sensor sample, the status code and the residuals.
        """
        t = np.asarray(sensor_t_s, float).ravel()
        n = t.size
        roll = np.broadcast_to(np.asarray(sensor_roll_rad, float), (n,))
        pitch = np.broadcast_to(np.asarray(sensor_pitch_rad, float), (n,))
        truth_t = np.asarray(truth_t_s, float).ravel()
        q = np.asarray(q_truth, float).reshape(4, truth_t.size)
        arrival = np.asarray(truth_arrival, np.int64).ravel()
        if arrival.size != truth_t.size or (arrival.size and (np.any(np.diff(arrival) < 0) or arrival[0] < 0
                                                              or arrival[-1] > n)):
            raise ValueError("truth_arrival must give, for each truth sample, a non-decreasing sensor index 0 … N")
        now = None if now_s is None else np.broadcast_to(np.asarray(now_s, float), (n,))
        if odometry is not None:
            odometry = tuple(np.asarray(part, float).reshape(3, n) for part in odometry)
        given_model = oblateness_roll_rad is not None and oblateness_pitch_rad is not None
        inputs = dict(t=t, roll=roll, pitch=pitch, truth_t=truth_t, q=q, arrival=arrival, now=now,
                      odometry=odometry, max_age=float(odometry_max_age_s), u=u_rad, altitude=altitude_m,
                      inclination=inclination_rad,
                      model=(oblateness_roll_rad, oblateness_pitch_rad) if given_model else None)
        scan = None
        if not self._pending and n:
            scan = self._scan_clean_batch(inputs)
            if scan is None:
                scan = self._scan_batch(inputs)
        plan = None if scan is None else self._plan_batch(inputs, scan)
        if plan is not None:
            return self._apply_batch(t, scan, plan)
        return self._add_batch_per_sample(inputs)

    def _add_batch_per_sample(self, inputs) -> "BatchOutcome":
        """:meth:`add_batch` one call per sample: exact by definition."""
        t, roll, pitch, truth_t, q, arrival, now = (inputs[k] for k in ("t", "roll", "pitch", "truth_t", "q",
                                                                        "arrival", "now"))
        n = t.size
        result = BatchOutcome.empty(n)
        index_of_stamp = {}
        j = 0
        for i in range(n + 1):
            clock = None if now is None else float(now[min(i, n - 1)])
            while j < truth_t.size and arrival[j] == i:
                result.take(self.add_truth_quaternion(float(truth_t[j]), q[:, j], now_s=clock), index_of_stamp)
                j += 1
            if i == n:
                break
            if inputs["odometry"] is not None:
                position, velocity = inputs["odometry"]
                self.add_odometry(float(t[i]), position[:, i], velocity[:, i], now_s=clock)
                result.take(self.take_settled(), index_of_stamp)
                orbit = self.orbit_at(float(t[i]), inputs["max_age"])
            else:
                orbit = dict(u_rad=_element(inputs["u"], i), altitude_m=inputs["altitude"],
                             inclination_rad=inputs["inclination"])
            if inputs["model"] is not None:
                orbit.update(oblateness_roll_rad=_element(inputs["model"][0], i),
                             oblateness_pitch_rad=_element(inputs["model"][1], i))
            outcomes = self.add_sensor(float(t[i]), float(roll[i]), float(pitch[i]), now_s=clock, **orbit)
            own = [o for o in outcomes if isinstance(o.status, Rejection)]
            if own:
                result.status[i] = BATCH_STATUSES.index(own[0].status)
                outcomes = [o for o in outcomes if o is not own[0]]
            else:
                index_of_stamp[float(t[i])] = i
            result.take(outcomes, index_of_stamp)
        return result

    def _scan_clean_batch(self, inputs):
        """:meth:`_scan_batch` on arrays for a clean batch — every stamp on its stream's timeline, increasing
        at no more than the rate limit and not in the future, the node clock steady — else None.

        What a campaign's flight always is. Its verdicts are those of the sample-by-sample scan: the
        checks that can reject a clean stamp (angles, quaternions, orbit states) run on every sample; a
        batch in which any stamp or clock reading would need the jump rule goes the scalar way.
        """
        t, truth_t, arrival, now = inputs["t"], inputs["truth_t"], inputs["arrival"], inputs["now"]
        n, m = t.size, truth_t.size
        bounds = self.config.bounds
        clock, stamps = self._clock, self._stamps
        if clock.suspect_s is not None or any(check.jumps.suspect_s is not None for check in stamps.values()):
            return None
        counters = dict.fromkeys(COUNTER_NAMES, 0)
        # The node clock: every reading on the timeline (never back, never a forward jump), so each is "now".
        if now is not None:
            now = np.asarray(now, float)
            if not np.all(np.isfinite(now)) or np.any(np.diff(now) < 0.0):
                return None
            first = clock.latest_s
            if first is not None and not (first - clock.threshold_s <= now[0] <= first + clock.forward_threshold_s):
                return None
            if np.any(np.diff(now) > clock.forward_threshold_s):
                return None
            clock_now = now if first is None else np.maximum(now, first)
        truth_now = None if now is None else now[np.minimum(arrival, n - 1)]

        def stamps_clean(check, stamp, clock_at):
            """Whether ``check`` accepts every one of the increasing ``stamp`` as it stands, with no jump."""
            if stamp.size == 0:
                return True
            if not np.all(np.isfinite(stamp)) or np.any(stamp <= 0.0):
                return False
            if clock_at is not None and np.any(stamp > clock_at + check.future_tolerance_s):
                return False
            steps = np.diff(stamp)
            if np.any(steps <= 0.0) or np.any(steps < check.min_interval_s):
                return False
            latest = check.jumps.latest_s
            return latest is None or (stamp[0] > latest and stamp[0] - latest >= check.min_interval_s)

        # Truth: the quaternion check on each (exactly as check_quaternion), then the stamps of the good ones.
        q = inputs["q"]
        q_finite = np.all(np.isfinite(q), axis=0)
        with np.errstate(invalid="ignore"):  # non-finite components: their norm is replaced by NaN just below
            norms = np.where(q_finite, _HYPOT_4(*q).astype(float), math.nan) if m else np.empty(0)
        truth_ok = q_finite & (np.abs(norms - 1.0) <= QUATERNION_NORM_TOLERANCE)
        counters["truth_received"] = m
        counters[f"rejected_truth_{Rejection.NON_FINITE.value}"] = int(m - np.count_nonzero(q_finite))
        counters[f"rejected_truth_{Rejection.BAD_QUATERNION.value}"] = int(np.count_nonzero(q_finite & ~truth_ok))
        counters["truth_quaternions_normalised"] = int(np.count_nonzero(
            truth_ok & (np.abs(norms - 1.0) > UNIT_ROUNDING)))
        if not stamps_clean(stamps["truth"], truth_t[truth_ok], None if now is None else truth_now[truth_ok]):
            return None
        q_ok = np.full((4, m), math.nan)
        q_ok[:, truth_ok] = q[:, truth_ok] / norms[truth_ok]
        # Odometry at each sensor stamp: plausible states (with a margin on every bound; a state near one
        # goes the scalar way), then the stamps.
        odometry = inputs["odometry"]
        odometry_ok = np.zeros(n, bool)
        if odometry is not None:
            position, velocity = odometry
            if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
                return None
            radius = np.sqrt(np.sum(position * position, axis=0))
            speed = np.sqrt(np.sum(velocity * velocity, axis=0))
            margin = 1.0 + 1e-9
            plausible = ((bounds.min_orbit_radius_m * margin < radius) & (radius * margin < bounds.max_orbit_radius_m)
                         & (bounds.min_orbit_speed_m_s * margin < speed) & (speed * margin < bounds.max_orbit_speed_m_s)
                         & (0.5 * speed * speed * margin < GM_EARTH_M3_S2 / radius))
            if not np.all(plausible) or not stamps_clean(stamps["odometry"], t, now):
                return None
            counters["odometry_received"] = n
            odometry_ok[:] = True
        # Sensor: the angle check (NaN passes: a lost pair), then the stamps of the good ones.
        roll, pitch = inputs["roll"], inputs["pitch"]
        limit = bounds.max_abs_angle_rad  # check_angles looks at roll first, then pitch
        roll_infinite, roll_large = np.isinf(roll), ~np.isinf(roll) & (np.abs(roll) > limit)
        pitch_infinite, pitch_large = np.isinf(pitch), ~np.isinf(pitch) & (np.abs(pitch) > limit)
        roll_fine = ~roll_infinite & ~roll_large
        infinite = roll_infinite | (roll_fine & pitch_infinite)
        too_large = roll_large | (roll_fine & pitch_large)
        sensor_ok = ~infinite & ~too_large
        if not stamps_clean(stamps["sensor"], t[sensor_ok], None if now is None else now[sensor_ok]):
            return None
        sensor_code = np.full(n, PENDING_CODE, np.int8)
        sensor_code[infinite] = BATCH_STATUSES.index(Rejection.NON_FINITE)
        sensor_code[too_large] = BATCH_STATUSES.index(Rejection.IMPLAUSIBLE_ANGLE)
        counters["sensor_received"] = n
        counters[f"rejected_sensor_{Rejection.NON_FINITE.value}"] = int(np.count_nonzero(infinite))
        counters[f"rejected_sensor_{Rejection.IMPLAUSIBLE_ANGLE.value}"] = int(np.count_nonzero(too_large))
        # Events in arrival order: before sensor sample i, the truth samples arriving at i.
        sensor_event = np.arange(n) + np.searchsorted(arrival, np.arange(n), side="right")
        truth_event = np.arange(m) + arrival
        # What _expire compares with after each event: the newest accepted sensor stamp or the clock.
        newest = stamps["sensor"].latest_s
        accepted = np.where(sensor_ok, t, -math.inf)
        newest_after = np.maximum.accumulate(accepted) if n else accepted
        if newest is not None:
            newest_after = np.maximum(newest_after, newest)
        before = np.concatenate([[-math.inf if newest is None else newest], newest_after])  # before sample i
        expiry_clock = np.empty(n + m)
        expiry_clock[sensor_event] = newest_after
        expiry_clock[truth_event] = before[arrival]
        if now is not None:
            expiry_clock[sensor_event] = np.maximum(expiry_clock[sensor_event], clock_now)
            expiry_clock[truth_event] = np.maximum(expiry_clock[truth_event], clock_now[np.minimum(arrival, n - 1)])
        # The state after the batch, on copies, as the scalar scan leaves it.
        stamps = {stream: copy.deepcopy(check) for stream, check in stamps.items()}
        for stream, good in (("truth", truth_t[truth_ok]), ("sensor", t[sensor_ok]),
                             ("odometry", t if odometry is not None else t[:0])):
            if good.size:
                stamps[stream].jumps.latest_s = float(good[-1])
        clock = copy.deepcopy(clock)
        if now is not None and n:
            clock.latest_s = float(clock_now[-1])
        return dict(stamps=stamps, clock=clock, counters=counters, sensor_code=sensor_code,
                    sensor_event=sensor_event, truth_event=truth_event[truth_ok], truth_t=truth_t[truth_ok],
                    q_truth=q_ok[:, truth_ok], expiry_clock=expiry_clock, odometry_ok=odometry_ok)

    def _scan_batch(self, inputs):
        """Validate a batch in arrival order on copies of the stamp and clock state; None if the array form
        cannot follow it (a jump, an outlier, an unconfirmed stamp)."""
        stamps = {stream: copy.deepcopy(check) for stream, check in self._stamps.items()}
        clock = copy.deepcopy(self._clock)
        counters = dict.fromkeys(COUNTER_NAMES, 0)
        t, truth_t, arrival, now = inputs["t"], inputs["truth_t"], inputs["arrival"], inputs["now"]
        n, m = t.size, truth_t.size
        sensor_code = np.full(n, PENDING_CODE, np.int8)
        sensor_event = np.empty(n, np.int64)
        truth_event = np.empty(m, np.int64)
        truth_ok = np.zeros(m, bool)
        odometry_ok = np.zeros(n, bool)
        q_ok = np.empty((4, m))
        expiry_clock = []  # what _expire compares with after each event
        bounds = self.config.bounds
        t_list, roll_list, pitch_list = t.tolist(), inputs["roll"].tolist(), inputs["pitch"].tolist()
        truth_list, q_list, arrival_list = truth_t.tolist(), inputs["q"].T.tolist(), arrival.tolist()
        now_list = None if now is None else now.tolist()
        odometry = inputs["odometry"]
        states = None if odometry is None else list(zip(odometry[0].T.tolist(), odometry[1].T.tolist()))
        sensor_check, truth_check, odometry_check = stamps["sensor"], stamps["truth"], stamps["odometry"]

        def observe(value):
            if value is None or not math.isfinite(value):
                return True, None
            return clock.observe(value) is Jump.NONE, clock.latest_s

        def expiry(clock_s):
            latest = sensor_check.latest_s
            if clock_s is not None:
                latest = clock_s if latest is None else max(latest, clock_s)
            return -math.inf if latest is None else latest

        def stamp_verdict(check, stamp, now_i):
            outliers = check.outliers
            rejection, jumped = check.check(stamp, now_i)
            steady = not jumped and check.outliers == outliers and rejection is not Rejection.UNCONFIRMED_JUMP
            return steady, rejection

        j = event = 0
        for i in range(n + 1):
            now_i = None if now_list is None else now_list[min(i, n - 1)]
            while j < m and arrival_list[j] == i:
                counters["truth_received"] += 1
                steady, clock_s = observe(now_i)
                if not steady:
                    return None
                unit, rejection, normalised = check_quaternion(q_list[j])
                if rejection is None:
                    counters["truth_quaternions_normalised"] += normalised
                    steady, rejection = stamp_verdict(truth_check, truth_list[j], now_i)
                    if not steady:
                        return None
                if rejection is not None:
                    counters[f"rejected_truth_{rejection.value}"] += 1
                else:
                    truth_ok[j] = True
                    q_ok[:, j] = unit
                truth_event[j] = event
                expiry_clock.append(expiry(clock_s))
                event += 1
                j += 1
            if i == n:
                break
            if states is not None:  # add_odometry: the clock is observed, nothing expires
                counters["odometry_received"] += 1
                steady, _ = observe(now_i)
                if not steady:
                    return None
                rejection = check_orbit_state(*states[i], bounds)
                if rejection is None:
                    steady, rejection = stamp_verdict(odometry_check, t_list[i], now_i)
                    if not steady:
                        return None
                if rejection is not None:
                    counters[f"rejected_odometry_{rejection.value}"] += 1
                else:
                    odometry_ok[i] = True
            counters["sensor_received"] += 1
            steady, clock_s = observe(now_i)
            if not steady:
                return None
            rejection = check_angles(roll_list[i], pitch_list[i], bounds.max_abs_angle_rad, allow_nan=True)
            if rejection is None:
                steady, rejection = stamp_verdict(sensor_check, t_list[i], now_i)
                if not steady:
                    return None
            if rejection is not None:
                counters[f"rejected_sensor_{rejection.value}"] += 1
                sensor_code[i] = BATCH_STATUSES.index(rejection)
            sensor_event[i] = event
            expiry_clock.append(expiry(clock_s))
            event += 1
        return dict(stamps=stamps, clock=clock, counters=counters, sensor_code=sensor_code,
                    sensor_event=sensor_event, truth_event=truth_event[truth_ok], truth_t=truth_t[truth_ok],
                    q_truth=q_ok[:, truth_ok], expiry_clock=np.array(expiry_clock), odometry_ok=odometry_ok)

    def _batch_orbit(self, inputs, scan):
        """Per sensor sample: (u, inclination, altitude) as add_sensor takes them (NaN: none), and the
        orbit record the monitor keeps after the batch."""
        t, config = inputs["t"], self.config
        n = t.size
        if inputs["odometry"] is None:
            u = np.full(n, np.nan) if inputs["u"] is None else np.broadcast_to(np.asarray(inputs["u"], float), (n,))
            altitude = config.altitude_m if inputs["altitude"] is None else inputs["altitude"]
            inclination = config.inclination_rad if inputs["inclination"] is None else inputs["inclination"]
            return (u, np.full(n, np.nan if inclination is None else float(inclination)),
                    np.full(n, np.nan if altitude is None else float(altitude)), self._orbit)
        # orbit_at: the latest accepted odometry no further than max_age from the stamp, u advanced at its rate.
        ok = scan["odometry_ok"]
        records = _orbit_records(t[ok], inputs["odometry"][0][:, ok], inputs["odometry"][1][:, ok])
        if self._orbit is not None:
            records = np.c_[np.asarray(self._orbit, float)[:, None], records]
        latest = np.cumsum(ok) - 1 + (self._orbit is not None)  # index of the latest record at each sample
        have = latest >= 0
        stamp, u0, inclination0, altitude0, rate = (np.r_[column, np.nan][np.where(have, latest, -1)]
                                                    for column in records)
        fresh = have & (np.abs(t - stamp) <= inputs["max_age"])
        u = np.where(fresh, u0 + rate * (t - stamp), np.nan)
        nominal_inclination = np.nan if config.inclination_rad is None else config.inclination_rad
        inclination = np.where(fresh, inclination0, nominal_inclination)
        altitude = np.where(fresh, altitude0, np.nan if config.altitude_m is None else config.altitude_m)
        orbit = self._orbit if not records.shape[1] else tuple(float(c) for c in records[:, -1])
        return u, inclination, altitude, orbit

    def _plan_batch(self, inputs, scan):
        """The alignment of a validated batch on arrays; None where the per-sample path could differ."""
        config = self.config
        t, roll, pitch = inputs["t"], inputs["roll"], inputs["pitch"]
        code = scan["sensor_code"]
        accepted = code == PENDING_CODE
        no_angle = accepted & np.isnan(roll) & np.isnan(pitch)
        valid = np.flatnonzero(accepted & ~no_angle)
        # Truth: what the buffer holds (arrived before the batch), then the batch's accepted samples.
        prior = len(self._truth_t)
        truth_t = np.r_[np.asarray(self._truth_t, float), scan["truth_t"]]
        if scan["truth_t"].size:
            new_roll, new_pitch = true_roll_pitch(scan["q_truth"])
        else:
            new_roll = new_pitch = np.empty(0)
        truth_roll = np.r_[np.asarray(self._truth_roll, float), np.atleast_1d(new_roll)]
        truth_pitch = np.r_[np.asarray(self._truth_pitch, float), np.atleast_1d(new_pitch)]
        truth_event = np.r_[np.full(prior, -1, np.int64), scan["truth_event"]]
        clocks = scan["expiry_clock"]
        events = clocks.size
        stamp = t[valid]
        arrive = scan["sensor_event"][valid]
        hi = np.searchsorted(truth_t, stamp, side="left")  # the first truth at or after each stamp
        have = hi < truth_t.size
        cover_event = np.where(have, np.r_[truth_event, 0][hi], events)
        at_once = have & (cover_event < arrive)
        # Given up: the first event from its arrival on whose clock is more than max_truth_wait_s past it.
        expire = np.maximum(_first_expired(clocks, stamp, config.max_truth_wait_s), arrive)
        stale = ~at_once & (expire < cover_event)
        aligned = ~stale & have
        waiting = ~at_once & ~stale & ~have
        settle = np.where(at_once, arrive, np.where(stale, expire, np.where(have, cover_event, events)))
        # The pending queue (samples not aligned on arrival) must never overflow.
        queued = ~at_once
        queued_settle = settle[queued]
        if queued_settle.size:
            if np.any(np.diff(queued_settle) < 0):
                return None
            length = np.arange(1, queued_settle.size + 1) - np.searchsorted(queued_settle, arrive[queued], "left")
            if length.max() > config.max_pending:
                return None
        # The bracketing truth must still be in the buffer when the sample is aligned (history, capacity).
        lo = hi - 1
        arrived = np.where(at_once, np.searchsorted(truth_event, arrive, side="left"),
                           np.minimum(hi + 1, truth_t.size))
        floor = arrived - config.truth_capacity - np.where(at_once, 0, 1)
        latest = truth_t[np.maximum(arrived - 1, 0)] if truth_t.size else np.zeros(stamp.size)
        kept_from = np.searchsorted(truth_t, latest - config.truth_history_s, side="right") - 1
        first = aligned & (hi == 0)
        if np.any(aligned & (hi > 0) & ((lo < floor) | (at_once & (lo < kept_from)))):
            return None
        if np.any(first & ((floor > 0) | (kept_from > 0))):
            return None
        exact = aligned & (np.r_[truth_t, np.nan][hi] == stamp)
        no_truth = aligned & ~exact & (hi == 0)
        span = np.r_[truth_t, np.nan][hi] - np.r_[np.nan, truth_t][hi]
        gap = aligned & ~exact & ~no_truth & (span > config.max_truth_gap_s)
        used = aligned & ~no_truth & ~gap
        # Truth at each used stamp: the sample itself, or linear between the bracketing samples.
        k = np.flatnonzero(used)
        h, low, hit = hi[k], np.maximum(hi[k] - 1, 0), exact[k]
        weight = (stamp[k] - truth_t[low]) / np.where(hit, 1.0, truth_t[h] - truth_t[low])
        at_roll = np.where(hit, truth_roll[h], truth_roll[low] + weight * (truth_roll[h] - truth_roll[low]))
        at_pitch = np.where(hit, truth_pitch[h], truth_pitch[low] + weight * (truth_pitch[h] - truth_pitch[low]))
        # The oblateness model and the altitude, as add_sensor takes them.
        u, inclination, altitude, orbit = self._batch_orbit(inputs, scan)
        if inputs["model"] is not None:
            model_roll, model_pitch = (np.broadcast_to(np.asarray(part, float), t.shape) for part in inputs["model"])
        else:
            model_roll, model_pitch = np.full(t.shape, np.nan), np.full(t.shape, np.nan)
            known = np.isfinite(u) & np.isfinite(inclination) & (altitude > 0.0) & np.isfinite(altitude)
            if known.any():
                _, model_roll[known], model_pitch[known] = closed_form_oblateness(u[known], altitude[known],
                                                                                  inclination[known])
        rows = valid[k]
        return dict(no_angle=np.flatnonzero(no_angle), stale=valid[stale], waiting=valid[waiting],
                    no_truth=valid[no_truth], gap=valid[gap], used=rows,
                    residual_roll=roll[rows] - at_roll, residual_pitch=pitch[rows] - at_pitch,
                    model_roll=model_roll, model_pitch=model_pitch, altitude=altitude, orbit=orbit,
                    truth=(truth_t, truth_roll, truth_pitch), roll=roll, pitch=pitch)

    def _apply_batch(self, t, scan, plan) -> "BatchOutcome":
        """Commit a planned batch: stamps, counters, statistics, ring, truth buffer, orbit and pending queue."""
        config = self.config
        self._stamps, self._clock, self._orbit = scan["stamps"], scan["clock"], plan["orbit"]
        counters = self._counters
        for name, value in scan["counters"].items():
            counters[name] += value
        result = BatchOutcome.empty(t.size)
        result.status[:] = scan["sensor_code"]
        for rows, status in ((plan["no_angle"], Status.NO_VALID_ANGLE), (plan["stale"], Status.STALE_TRUTH),
                             (plan["gap"], Status.TRUTH_GAP),
                             (plan["no_truth"], Status.TOO_OLD if self._truth_pruned else Status.NO_TRUTH)):
            result.status[rows] = BATCH_STATUSES.index(status)
            counters[f"skipped_{status.value}"] += int(rows.size)
        rows = plan["used"]
        result.status[rows] = BATCH_STATUSES.index(Status.OK)
        residual_roll, residual_pitch = plan["residual_roll"], plan["residual_pitch"]
        counters["used"] += int(rows.size)
        counters["used_one_angle"] += int(np.count_nonzero(np.isnan(residual_roll) | np.isnan(residual_pitch)))
        # _account on arrays.
        roll_kept = residual_roll - config.roll_offset_rad
        pitch_kept = residual_pitch - config.pitch_offset_rad
        kept = (roll_kept, pitch_kept, np.hypot(roll_kept, pitch_kept))
        model_roll, model_pitch = plan["model_roll"][rows], plan["model_pitch"][rows]
        has_model = np.isfinite(model_roll) & np.isfinite(model_pitch)
        counters["used_without_oblateness_model"] += int(np.count_nonzero(~has_model))
        roll_removed = np.where(has_model, roll_kept - model_roll, np.nan)
        pitch_removed = np.where(has_model, pitch_kept - model_pitch, np.nan)
        removed = (roll_removed, pitch_removed, np.hypot(roll_removed, pitch_removed))
        altitude = plan["altitude"][rows]
        with_ground = np.isfinite(altitude) & (altitude > 0.0)
        for key, columns in ((False, kept), (True, removed)):
            target = self._sets[key]
            for stats, values in zip(target.angles, columns):
                stats.update(values[np.isfinite(values)])
            if with_ground.any():
                grounds = _ground_arrays(tuple(c[with_ground] for c in columns), altitude[with_ground])
                for stats, values in zip(target.ground, grounds):
                    stats.update(values[np.isfinite(values)])
        self._ring.add_many(t[rows], np.column_stack(removed + kept))
        primary = removed if config.remove_oblateness else kept
        result.residual_roll_rad[rows], result.residual_pitch_rad[rows] = residual_roll, residual_pitch
        result.roll_rad[rows], result.pitch_rad[rows], result.meridional_rad[rows] = primary
        # What stays for the next call: the truth buffer (pruned as the per-sample path prunes) and the queue.
        truth_t, truth_roll, truth_pitch = plan["truth"]
        self._truth_t[:], self._truth_roll[:], self._truth_pitch[:] = (truth_t.tolist(), truth_roll.tolist(),
                                                                       truth_pitch.tolist())
        roll, pitch = plan["roll"], plan["pitch"]
        for i in plan["waiting"].tolist():
            self._pending.append(PendingSample(float(t[i]), float(roll[i]), float(pitch[i]), float(plan["model_roll"][i]),
                                          float(plan["model_pitch"][i]), float(plan["altitude"][i])))
        if self._truth_t:
            self._prune_truth()
        return result
