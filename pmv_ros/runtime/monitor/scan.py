"""The error monitor's validation: every input in arrival order, into the segment the alignment settles.

:class:`EventScan` (a part of :class:`~pmv_ros.runtime.monitor.core.ErrorMonitor`)
checks each event — a truth, odometry or sensor sample, a poll of the clock —
with :mod:`pmv_ros.runtime.common.validation`, applies the clock-jump rule (a
confirmed jump settles what came before it and resets the alignment), and
gathers the accepted samples into the open segment, flagging it due when
something in it will settle.

:func:`scan_clean` gives what :class:`~pmv_ros.runtime.monitor.core.ErrorMonitor`'s
event-by-event scan gives — the same verdicts, counters, event numbers and
timeout clocks, and the same stamp and clock state after it — for a batch in
which no stamp and no clock reading needs the jump rule: every stamp on its
stream's timeline, rising at no more than the rate limit and not in the
future, the node clock steady. The checks that can refuse a clean stamp
(angles, quaternions, orbit states) run on every sample. Any other batch,
and a short one (where numpy's per-call cost is more than the loop's), gets
``None`` and goes event by event.

The two scans are a twin kept on purpose: a node's messages always go event
by event, a campaign's flight is one clean batch of an orbit, and the array
scan is most of what makes a campaign's monitor cheap —
``design/twin_scan_clean.py`` measures what it buys, and
``tests/runtime/test_monitor.py::test_the_array_scan_of_a_clean_batch_is_the_event_scan``
holds the two to the same verdicts. A change to a check here is a change
there (and in :mod:`pmv_ros.runtime.common.validation`, whose checks the
event scan calls).
"""


from __future__ import annotations

import math

import numpy as np

from ...physics.attitude import true_roll_pitch
from ...physics.constants import GM_EARTH_M3_S2
from ...physics.orbit.two_body import orbit_angles_from_state
from .alignment import Segment, oblateness_model
from .records import BATCH_STATUSES, ODOMETRY_EVENT, PENDING_CODE, POLL_EVENT, SENSOR_EVENT, TRUTH_EVENT, Feed, \
    Status, orbit_record
from ..common.validation import (
    QUATERNION_NORM_TOLERANCE,
    UNIT_ROUNDING,
    Jump,
    Rejection,
    check_angles,
    check_orbit_state,
    check_quaternion,
)

_NO_ANGLE = BATCH_STATUSES.index(Status.NO_VALID_ANGLE)

#: Below this many sensor samples a batch goes event by event.
MIN_ARRAY_SAMPLES = 32

#: ``math.hypot`` of four arrays, element by element: the norm check_quaternion takes (numpy's hypot has two
#: arguments and rounds otherwise).
_HYPOT_4 = np.frompyfunc(math.hypot, 4, 1)


def _as_list(column) -> list:
    return column if isinstance(column, list) else column.tolist()


def _orbit_records(t_s: np.ndarray, position_eci_m: np.ndarray, velocity_eci_m_s: np.ndarray) -> np.ndarray:
    """:func:`~pmv_ros.runtime.monitor.records.orbit_record` of ``(N,)`` stamps and ``(3, N)`` states: ``(5, N)``."""
    u, inclination, altitude = orbit_angles_from_state(position_eci_m, velocity_eci_m_s)
    rate = np.linalg.norm(velocity_eci_m_s, axis=0) / np.linalg.norm(position_eci_m, axis=0)
    return np.vstack([t_s, u, inclination, altitude, rate])


def _stamps_clean(check, stamp: np.ndarray, clock_at) -> bool:
    """Whether ``check`` accepts every one of the rising ``stamp`` as it stands, with no jump."""
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


def _odometry_at_sensors(feed: Feed) -> bool:
    """Whether the odometry is one state at each sensor stamp, just before it (:meth:`ErrorMonitor.add_batch`)."""
    n = feed.t_s.size
    return (feed.odometry_t_s.size == n and np.array_equal(feed.odometry_t_s, feed.t_s)
            and np.array_equal(feed.odometry_arrival, np.arange(n))
            and (feed.odometry_now_s is None) == (feed.sensor_now_s is None)
            and (feed.sensor_now_s is None or np.array_equal(feed.odometry_now_s, feed.sensor_now_s)))


def scan_clean(monitor, feed: Feed) -> Segment | None:
    """The segment of a clean batch, with ``monitor``'s counters, timelines and orbit moved past it; or None
    (nothing touched) for a batch that needs the event-by-event scan."""
    if feed.order is not None:  # a node's messages, in the order they came: event by event
        return None
    t, truth_t, arrival, now = feed.t_s, feed.truth_t_s, feed.truth_arrival, feed.sensor_now_s
    n, m = t.size, truth_t.size
    if n < MIN_ARRAY_SAMPLES or feed.poll_now_s is not None or feed.truth.shape[0] != 4:
        return None
    with_odometry = feed.odometry_t_s.size > 0
    if with_odometry and not _odometry_at_sensors(feed):
        return None
    if feed.truth_now_s is not None and (now is None or not np.array_equal(feed.truth_now_s,
                                                                          now[np.minimum(arrival, n - 1)])):
        return None
    config, bounds = monitor.config, monitor.config.bounds
    clock, stamps = monitor._clock, monitor._stamps
    if clock.suspect_s is not None or any(check.jumps.suspect_s is not None for check in stamps.values()):
        return None
    counters = {}
    # The node clock: every reading on the timeline (never back, never a forward jump), so each is "now".
    if now is not None:
        if not np.all(np.isfinite(now)) or np.any(np.diff(now) < 0.0):
            return None
        first = clock.latest_s
        if first is not None and not (first - clock.threshold_s <= now[0] <= first + clock.forward_threshold_s):
            return None
        if np.any(np.diff(now) > clock.forward_threshold_s):
            return None
        clock_now = now if first is None else np.maximum(now, first)
    truth_now = None if now is None else now[np.minimum(arrival, n - 1)]
    # Truth: the quaternion check on each (exactly as check_quaternion), then the stamps of the good ones.
    q = feed.truth
    q_finite = np.all(np.isfinite(q), axis=0)
    with np.errstate(invalid="ignore"):  # non-finite components: their norm is replaced by NaN just below
        norms = np.where(q_finite, _HYPOT_4(*q).astype(float), math.nan) if m else np.empty(0)
    truth_ok = q_finite & (np.abs(norms - 1.0) <= QUATERNION_NORM_TOLERANCE)
    counters["truth_received"] = m
    counters[f"rejected_truth_{Rejection.NON_FINITE.value}"] = int(m - np.count_nonzero(q_finite))
    counters[f"rejected_truth_{Rejection.BAD_QUATERNION.value}"] = int(np.count_nonzero(q_finite & ~truth_ok))
    counters["truth_quaternions_normalised"] = int(np.count_nonzero(truth_ok & (np.abs(norms - 1.0) > UNIT_ROUNDING)))
    if not _stamps_clean(stamps["truth"], truth_t[truth_ok], None if now is None else truth_now[truth_ok]):
        return None
    # Odometry at each sensor stamp: plausible states (with a margin on every bound; a state near one goes
    # event by event), then the stamps.
    if with_odometry:
        position, velocity = feed.odometry_position_m, feed.odometry_velocity_m_s
        if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
            return None
        radius = np.sqrt(np.sum(position * position, axis=0))
        speed = np.sqrt(np.sum(velocity * velocity, axis=0))
        margin = 1.0 + 1e-9
        with np.errstate(divide="ignore"):  # a state at the centre: infinite energy bound, refused below
            plausible = ((bounds.min_orbit_radius_m * margin < radius)
                         & (radius * margin < bounds.max_orbit_radius_m)
                         & (bounds.min_orbit_speed_m_s * margin < speed)
                         & (speed * margin < bounds.max_orbit_speed_m_s)
                         & (0.5 * speed * speed * margin < GM_EARTH_M3_S2 / radius))
        if not np.all(plausible) or not _stamps_clean(stamps["odometry"], t, now):
            return None
        counters["odometry_received"] = n
    # Sensor: the angle check (NaN passes: a lost pair; check_angles looks at roll first), then the stamps.
    roll, pitch = feed.roll_rad, feed.pitch_rad
    limit = bounds.max_abs_angle_rad
    roll_infinite, roll_large = np.isinf(roll), ~np.isinf(roll) & (np.abs(roll) > limit)
    pitch_infinite, pitch_large = np.isinf(pitch), ~np.isinf(pitch) & (np.abs(pitch) > limit)
    roll_fine = ~roll_infinite & ~roll_large
    infinite = roll_infinite | (roll_fine & pitch_infinite)
    too_large = roll_large | (roll_fine & pitch_large)
    sensor_ok = ~infinite & ~too_large
    if not _stamps_clean(stamps["sensor"], t[sensor_ok], None if now is None else now[sensor_ok]):
        return None
    # Clean: from here on the monitor's state moves.
    sensor_code = np.full(n, PENDING_CODE, np.int64)
    sensor_code[sensor_ok & np.isnan(roll) & np.isnan(pitch)] = _NO_ANGLE  # settles on arrival
    sensor_code[infinite] = BATCH_STATUSES.index(Rejection.NON_FINITE)
    sensor_code[too_large] = BATCH_STATUSES.index(Rejection.IMPLAUSIBLE_ANGLE)
    counters["sensor_received"] = n
    counters[f"rejected_sensor_{Rejection.NON_FINITE.value}"] = int(np.count_nonzero(infinite))
    counters[f"rejected_sensor_{Rejection.IMPLAUSIBLE_ANGLE.value}"] = int(np.count_nonzero(too_large))
    for name, value in counters.items():
        monitor._counters[name] += value
    # Events in arrival order: before sensor sample i, the truth samples arriving at i.
    sensor_event = np.arange(n) + np.searchsorted(arrival, np.arange(n), side="right")
    truth_event = np.arange(m) + arrival
    # What a timeout compares with after each event: the newest accepted sensor stamp or the clock.
    newest = stamps["sensor"].latest_s
    accepted = np.where(sensor_ok, t, -math.inf)
    newest_after = np.maximum.accumulate(accepted)
    if newest is not None:
        newest_after = np.maximum(newest_after, newest)
    before = np.concatenate([[-math.inf if newest is None else newest], newest_after])  # before sample i
    expiry_clock = np.empty(n + m)
    expiry_clock[sensor_event] = newest_after
    expiry_clock[truth_event] = before[arrival]
    if now is not None:
        expiry_clock[sensor_event] = np.maximum(expiry_clock[sensor_event], clock_now)
        expiry_clock[truth_event] = np.maximum(expiry_clock[truth_event], clock_now[np.minimum(arrival, n - 1)])
    for stream, good in (("truth", truth_t[truth_ok]), ("sensor", t[sensor_ok]),
                         ("odometry", t if with_odometry else t[:0])):
        if good.size:
            stamps[stream].jumps.latest_s = float(good[-1])
    if now is not None:
        clock.latest_s = float(clock_now[-1])
    # The oblateness model of each sample: given, or at its orbit — its own odometry (just before it, so
    # of age 0) or the orbit columns.
    if with_odometry:
        records = _orbit_records(t, feed.odometry_position_m, feed.odometry_velocity_m_s)
        monitor._orbit = tuple(float(c) for c in records[:, -1])
        u, inclination, altitude = records[1], records[2], records[3]
    elif feed.odometry_max_age_s is not None:
        u = np.full(n, math.nan)
        inclination = np.full(n, math.nan if config.inclination_rad is None else config.inclination_rad)
        altitude = np.full(n, math.nan if config.altitude_m is None else config.altitude_m)
        if monitor._orbit is not None:
            stamp, u0, inclination0, altitude0, rate = monitor._orbit
            fresh = np.abs(t - stamp) <= feed.odometry_max_age_s
            u = np.where(fresh, u0 + rate * (t - stamp), u)
            inclination = np.where(fresh, inclination0, inclination)
            altitude = np.where(fresh, altitude0, altitude)
    else:
        u, inclination, altitude = feed.u_rad, feed.inclination_rad, feed.altitude_m
    if feed.model_roll_rad is not None:
        model_roll, model_pitch = feed.model_roll_rad, feed.model_pitch_rad
    else:
        model_roll, model_pitch = oblateness_model(u, altitude, inclination)
    truth_roll, truth_pitch = (true_roll_pitch(q[:, truth_ok] / norms[truth_ok]) if np.any(truth_ok)
                               else (np.empty(0), np.empty(0)))
    samples = np.vstack((np.arange(n, dtype=float), t, roll, pitch, np.broadcast_to(model_roll, (n,)),
                         np.broadcast_to(model_pitch, (n,)), np.broadcast_to(altitude, (n,))))
    truth = np.vstack((truth_t[truth_ok], np.atleast_1d(truth_roll), np.atleast_1d(truth_pitch)))
    return Segment(samples, sensor_code, sensor_event, truth, truth_event[truth_ok], expiry_clock,
                   bool(np.any(sensor_code != PENDING_CODE)))


#: The open segment is settled at this many events whatever they are (memory stays bounded).
OPEN_EVENTS = 256


class OpenSegment:
    """The open segment: events scanned since the last settle, not settled yet (nothing in them had to be).

    An event settles nothing unless truth arrives (it may cover waiting samples; it goes into the buffer), a
    sample is covered on arrival, a wait runs out, the queue overflows, or a sample is refused or has no
    angle; the scan flags those (``due``) and the segment is settled at the end of that input. So a 10 Hz
    sensor with 2 Hz truth costs the arrays twice a second, and between inputs the open segment holds only
    sensor samples that wait.
    """

    def __init__(self) -> None:
        self.sensor: list = []      # per sample: _SAMPLE_COLUMNS
        self.truth: list = []       # (stamp, roll, pitch, event)
        self.expiry: list = []      # per event: what times waiting samples out
        self.due = False
        self.on_arrival = False     # a sample in it settles on arrival (refused, or with neither angle)
        self.waiting = 0            # samples in it that may wait for truth
        self.oldest_s = math.inf    # the oldest of them


#: A gathered sensor sample: the input it came with and its place there, its verdict and event, its values, its
#: orbit (u and inclination NaN where unknown, or where the model came with the sample), its altitude (for the
#: ground error) and the oblateness model given with it (NaN: none given; computed from the orbit when the segment
#: is made, on arrays).
_SAMPLE_COLUMNS = ("serial", "index", "code", "event", "t_s", "roll_rad", "pitch_rad", "u_rad", "inclination_rad",
                   "altitude_m", "model_roll_rad", "model_pitch_rad")


class EventScan:
    """The event-by-event validation of :class:`~pmv_ros.runtime.monitor.core.ErrorMonitor` (any input, clock
    jumps included), on the monitor's timelines (``_stamps``, ``_clock``), counters, orbit, alignment and
    open segment; a confirmed jump calls the monitor's ``_reset``."""

    def _segment(self, gathered: OpenSegment) -> Segment:
        """The open segment's events as a :class:`Segment`, with each sample's oblateness model (the one given with
        it, or the closed form at its orbit) and altitude."""
        (serial, index, code, event, t, roll, pitch, u, inclination, altitude, given_roll,
         given_pitch) = np.array(gathered.sensor, float).reshape(-1, len(_SAMPLE_COLUMNS)).T
        if gathered.sensor and gathered.sensor[0][0] != self._serial:  # gathered in order: the first is the oldest
            index = np.where(serial == self._serial, index, -1.0)  # a place in an earlier input means nothing
        model_roll, model_pitch = oblateness_model(u, altitude, inclination)
        given = np.isnan(u)  # the model came with the sample (or no orbit is known, and no model given: NaN)
        if given.any():
            model_roll, model_pitch = np.where(given, given_roll, model_roll), np.where(given, given_pitch, model_pitch)
        truth = np.array(gathered.truth, float).reshape(-1, 4).T
        samples = np.vstack((index, t, roll, pitch, model_roll, model_pitch, altitude))  # SAMPLE_ROWS
        return Segment(samples, code.astype(np.int64), event.astype(np.int64), truth[:3], truth[3].astype(np.int64),
                       np.array(gathered.expiry, float), gathered.on_arrival)

    def _scan_events(self, feed: Feed) -> None:
        """Validate ``feed`` event by event into the open segment; a confirmed clock jump settles what came
        before it and resets."""
        order = feed.order
        if order is None:
            n, m, k = len(feed.t_s), len(feed.truth_t_s), len(feed.odometry_t_s)
            if n + m + k == 1:
                order = [(SENSOR_EVENT, 0)] if n else [(TRUTH_EVENT, 0)] if m else [(ODOMETRY_EVENT, 0)]
            else:  # before sensor sample i, the truth arriving at i, then the odometry arriving at i
                truth_at, odometry_at = _as_list(feed.truth_arrival), _as_list(feed.odometry_arrival)
                order, j, o = [], 0, 0
                for i in range(n + 1):
                    while j < m and truth_at[j] <= i:
                        order.append((TRUTH_EVENT, j))
                        j += 1
                    while o < k and odometry_at[o] <= i:
                        order.append((ODOMETRY_EVENT, o))
                        o += 1
                    if i < n:
                        order.append((SENSOR_EVENT, i))
            if feed.poll_now_s is not None:
                order.append((POLL_EVENT, 0))
        handlers = self._HANDLERS
        for kind, index in order:
            handlers[kind](self, feed, index)

    def _restart(self) -> None:
        """A confirmed jump mid-input: settle the events before it, then reset (a new segment)."""
        self._reset()

    def _observe(self, now_s) -> float | None:
        """Watch the node clock for jumps; the clock that times out waiting samples (None: no clock).

        While a jump of the clock is unconfirmed, waiting samples are timed by the old clock (a forged
        /clock a year ahead must not expire them); the future-stamp check takes the clock as it reads.
        """
        if now_s is None or not math.isfinite(now_s):
            return None
        verdict = self._clock.observe(now_s)
        if verdict is Jump.CONFIRMED_BACK:
            self._counters["clock_jumps"] += 1
            self._restart()
            self._clock.observe(now_s)
        elif verdict is Jump.OUTLIER:
            self._counters["clock_outliers"] += 1
        return self._clock.latest_s

    def _check_stamp(self, stream: str, t_s: float, now_s) -> Rejection | None:
        """Check the stamp of a sample whose values passed; a confirmed jump resets the alignment once."""
        check = self._stamps[stream]
        outliers = check.outliers
        rejection, jumped = check.check(t_s, now_s)
        self._counters["clock_outliers"] += check.outliers - outliers
        if not jumped:
            return rejection
        self._counters["clock_jumps"] += 1
        self._restart()
        check.check(t_s, now_s)  # the first stamp of the new timeline
        return None

    def _close_event(self, clock_s) -> None:
        """End an event of the open segment: its timeout clock, and whether a wait runs out at it."""
        latest = self._stamps["sensor"].latest_s
        if clock_s is not None:
            latest = clock_s if latest is None else max(latest, clock_s)
        expiry = -math.inf if latest is None else latest
        gathered = self._open
        gathered.expiry.append(expiry)
        oldest = self._alignment.oldest_pending_s if self._alignment.pending_count else gathered.oldest_s
        if expiry - oldest > self.config.max_truth_wait_s or len(gathered.expiry) >= OPEN_EVENTS:
            gathered.due = True

    @staticmethod
    def _now(column, k: int):
        value = None if column is None else column[k]
        return None if value is None else float(value)

    def _truth_event(self, feed: Feed, j: int) -> None:
        self._counters["truth_received"] += 1
        now_s = self._now(feed.truth_now_s, j)
        clock_s = self._observe(now_s)
        t_s = float(feed.truth_t_s[j])
        truth = feed.truth[j] if isinstance(feed.truth, list) else feed.truth[:, j]
        if len(truth) == 4:
            unit, rejection, normalised = check_quaternion(truth)
            if rejection is None:
                self._counters["truth_quaternions_normalised"] += normalised
                roll, pitch = true_roll_pitch(unit)
        else:
            roll, pitch = float(truth[0]), float(truth[1])
            # Truth is complete, or it is no truth.
            rejection = None if math.isfinite(roll) and math.isfinite(pitch) else Rejection.NON_FINITE
        if rejection is None:
            rejection = self._check_stamp("truth", t_s, now_s)
        gathered = self._open
        if rejection is not None:
            self._counters[f"rejected_truth_{rejection.value}"] += 1
        else:
            gathered.truth.append((t_s, float(roll), float(pitch), len(gathered.expiry)))
            gathered.due = True  # truth goes into the buffer with the input that brought it
        self._close_event(clock_s)

    def _odometry_event(self, feed: Feed, k: int) -> None:
        self._counters["odometry_received"] += 1
        now_s = self._now(feed.odometry_now_s, k)
        self._observe(now_s)
        t_s = float(feed.odometry_t_s[k])
        if isinstance(feed.odometry_position_m, list):
            position, velocity = feed.odometry_position_m[k], feed.odometry_velocity_m_s[k]
        else:
            position, velocity = feed.odometry_position_m[:, k], feed.odometry_velocity_m_s[:, k]
        rejection = check_orbit_state(position, velocity, self.config.bounds)
        if rejection is None:
            rejection = self._check_stamp("odometry", t_s, now_s)
        self._odometry_rejection = rejection
        if rejection is not None:
            self._counters[f"rejected_odometry_{rejection.value}"] += 1
            return
        self._orbit = orbit_record(t_s, position, velocity)

    def _sensor_event(self, feed: Feed, i: int) -> None:
        self._counters["sensor_received"] += 1
        now_s = self._now(feed.sensor_now_s, i)
        clock_s = self._observe(now_s)
        t_s, roll, pitch = float(feed.t_s[i]), float(feed.roll_rad[i]), float(feed.pitch_rad[i])
        rejection = check_angles(roll, pitch, self.config.bounds.max_abs_angle_rad, allow_nan=True)
        if rejection is None:
            rejection = self._check_stamp("sensor", t_s, now_s)
        gathered = self._open
        code = PENDING_CODE
        if rejection is not None:
            self._counters[f"rejected_sensor_{rejection.value}"] += 1
            code = BATCH_STATUSES.index(rejection)
            gathered.due = gathered.on_arrival = True
        elif math.isnan(roll) and math.isnan(pitch):
            code = _NO_ANGLE
            gathered.due = gathered.on_arrival = True
        elif (self._stamps["truth"].latest_s or -math.inf) >= t_s:
            gathered.due = True  # covered on arrival
        else:
            gathered.waiting += 1
            gathered.oldest_s = min(gathered.oldest_s, t_s)
            if gathered.waiting + self._alignment.pending_count > self.config.max_pending:
                gathered.due = True
        gathered.sensor.append((self._serial, i, code, len(gathered.expiry), t_s, roll, pitch)
                               + self._orbit_of(feed, i, t_s))
        self._close_event(clock_s)

    def _orbit_of(self, feed: Feed, i: int, t_s: float) -> tuple:
        """(u, inclination, altitude, model roll, model pitch) of sensor sample ``i`` of ``feed``: its orbit (the
        odometry's, or the orbit columns; NaN where unknown) and NaN for the model, whose closed form is taken
        when the segment is made; or, where the model came with the sample, u and inclination NaN and that
        model."""
        if feed.odometry_max_age_s is not None:  # the orbit of ErrorMonitor.orbit_at, or the configured one
            orbit = self._orbit
            if orbit is not None and abs(t_s - orbit[0]) <= feed.odometry_max_age_s:
                stamp, u, inclination, altitude, rate = orbit
                u += rate * (t_s - stamp)
            else:
                config = self.config
                u = math.nan
                inclination = math.nan if config.inclination_rad is None else config.inclination_rad
                altitude = math.nan if config.altitude_m is None else float(config.altitude_m)
        else:
            u, inclination, altitude = float(feed.u_rad[i]), float(feed.inclination_rad[i]), float(feed.altitude_m[i])
        if feed.model_roll_rad is not None:
            return math.nan, math.nan, altitude, float(feed.model_roll_rad[i]), float(feed.model_pitch_rad[i])
        return u, inclination, altitude, math.nan, math.nan

    def _poll_event(self, feed: Feed, _: int) -> None:
        self._close_event(self._observe(feed.poll_now_s))

    #: The handler of each kind of event (TRUTH_EVENT, ODOMETRY_EVENT, SENSOR_EVENT, POLL_EVENT).
    _HANDLERS = (_truth_event, _odometry_event, _sensor_event, _poll_event)
