"""The error monitor's alignment with truth, on arrays: the truth buffer, the pending queue, what settles when.

:class:`Alignment` holds what the monitor remembers between inputs — the
truth buffer (pruned by history and capacity), the sensor samples waiting
for truth, the latest odometry — and settles one validated stretch of input
(:class:`Segment`) at once. A message from a node is a stretch of one event,
a campaign's flight a stretch of a whole orbit; the rules are those of the
monitor's docstring, applied event by event in arrival order:

* an accepted truth sample pops the waiting samples it covers (aligned, in
  queue order), then gives up those waiting longer than ``max_truth_wait_s``,
  then prunes the buffer (older than ``truth_history_s`` before the newest
  truth, but never what the oldest waiting sample needs; at most
  ``truth_capacity`` samples);
* an accepted sensor sample is aligned at once when truth at or after its
  stamp is already in, else it waits (the oldest waiting one is pushed out
  when the queue is full); then waiting samples time out;
* a sample is aligned on the two truth samples that bracket it in the buffer
  as it stands at that moment (exact stamp, or linear, never across a gap
  longer than ``max_truth_gap_s``).

Every one of those moments is computed on arrays (searches over the event
numbers), not replayed one event at a time: the settle event of a waiting
sample is the first truth event that covers it or the first event whose
clock is past its wait, whichever comes first; the queue is FIFO and its
samples settle in queue order, so its front at any event is one search away.
"""


from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...physics.instrument.oblateness import closed_form_oblateness
from .records import BATCH_STATUSES, PENDING_CODE, Status

#: Order of what settles within one event (the per-event order of the monitor's outcomes).
_OWN, _OVERFLOW, _STALE = 0, 1, 2

_OK, _NO_ANGLE, _NO_TRUTH, _TOO_OLD, _GAP, _STALE_CODE, _OVERFLOW_CODE, _RESET = (
    BATCH_STATUSES.index(status) for status in (Status.OK, Status.NO_VALID_ANGLE, Status.NO_TRUTH, Status.TOO_OLD,
                                                Status.TRUTH_GAP, Status.STALE_TRUTH, Status.PENDING_OVERFLOW,
                                                Status.RESET))


#: The rows of a segment's sample matrix and of the pending queue.
SAMPLE_ROWS = ("index", "t_s", "roll_rad", "pitch_rad", "model_roll_rad", "model_pitch_rad", "altitude_m")


@dataclass
class Segment:
    """One validated stretch of input, no clock jump inside (the scan's product), events numbered from 0.

    Events are the truth and sensor arrivals and a poll, in arrival order; ``expiry_clock_s[e]`` is what
    event e times waiting samples out with (the newest sensor stamp or the node clock, -inf: neither).
    """

    samples: np.ndarray        #: (7, n) :data:`SAMPLE_ROWS`: place in the caller's input (−1: an earlier
    #: input), stamp, roll, pitch, the oblateness model (NaN: none), altitude (NaN: none)
    sensor_code: np.ndarray    #: (n,) PENDING_CODE (accepted with an angle), or the code it settles with on
    #: arrival: its rejection's or NO_VALID_ANGLE's index in BATCH_STATUSES
    sensor_event: np.ndarray   #: (n,) its event number
    truth: np.ndarray          #: (3, m) accepted truth (stamp, roll, pitch), in arrival order
    truth_event: np.ndarray    #: (m,)
    expiry_clock_s: np.ndarray  #: (events,)
    on_arrival: bool = True    #: whether any sample settles on arrival (False: every code is PENDING_CODE)


class Settled:
    """Sensor samples settled by one input, in the order the monitor settled them.

    ``values`` ``(8, k)``: :data:`SETTLED_ROWS`; ``reported`` ``(3, k)``: :data:`REPORTED_ROWS`, what the
    monitor's accounting adds — as the sample entered the reported statistics, rad, NaN unless the sample
    was used (None until then).
    """

    __slots__ = ("values", "reported")

    def __init__(self, values: np.ndarray, reported: np.ndarray | None = None) -> None:
        self.values, self.reported = values, reported

    def rows(self) -> list:
        """The samples as rows of :data:`SETTLED_ROWS` (lists of floats, in settle order)."""
        return self.values.T.tolist()

    @property
    def size(self) -> int:
        return self.values.shape[1]

    @property
    def index(self) -> np.ndarray:
        return self.values[0].astype(np.int64)

    @property
    def t_s(self) -> np.ndarray:
        return self.values[1]

    @property
    def code(self) -> np.ndarray:
        return self.values[2].astype(np.int64)

    def row(self, name: str) -> np.ndarray:
        """One row by its name in :data:`SETTLED_ROWS` or :data:`REPORTED_ROWS`."""
        if name in SETTLED_ROWS:
            return self.values[SETTLED_ROWS.index(name)]
        return self.report()[REPORTED_ROWS.index(name)]

    def report(self) -> np.ndarray:
        """The reported rows, made (NaN) on first use."""
        if self.reported is None:
            self.reported = np.full((len(REPORTED_ROWS), self.size), np.nan)
        return self.reported

    def take(self, columns) -> "Settled":
        return Settled(self.values[:, columns], None if self.reported is None else self.reported[:, columns])

    @staticmethod
    def concatenate(parts) -> "Settled":
        parts = [part for part in parts if part.size]
        if len(parts) == 1:
            return parts[0]
        if not parts:
            return _NOTHING
        return Settled(np.concatenate([part.values for part in parts], axis=1),
                       np.concatenate([part.report() for part in parts], axis=1))


SETTLED_ROWS = ("index", "t_s", "code", "residual_roll_rad", "residual_pitch_rad", "model_roll_rad",
                "model_pitch_rad", "altitude_m")
REPORTED_ROWS = ("roll_rad", "pitch_rad", "meridional_rad")
_NOTHING = Settled(np.empty((len(SETTLED_ROWS), 0)), np.empty((len(REPORTED_ROWS), 0)))


def first_expired(clocks: np.ndarray, stamp: np.ndarray, wait_s: float, start: np.ndarray) -> np.ndarray:
    """Per stamp, the first event from ``start`` on whose clock is past it by more than ``wait_s``
    (``clocks.size``: none).

    The test is ``clock − stamp > wait_s`` in floats, as a waiting sample is timed out (a search on
    ``stamp + wait_s`` alone can be one event off by rounding). ``clocks`` may go back only where a reset
    of the clock within an event left the old reading on that event: each rising run is searched apart.
    """
    size = clocks.size
    # Float subtraction is monotone: if the latest clock is not past the oldest stamp, none is past any.
    if size == 0 or stamp.size == 0 or not clocks.max() - stamp.min() > wait_s:
        return np.full(stamp.shape, size, np.int64)
    bounds = [0, *(np.flatnonzero(clocks[1:] < clocks[:-1]) + 1).tolist(), size]
    found = np.full(stamp.shape, size, np.int64)
    for lo, hi in zip(bounds[:-1], bounds[1:]):  # within a rising run, a clock past a stamp stays past it
        first = np.maximum(lo + _first_past(clocks[lo:hi], stamp, wait_s), start)
        found = np.where(first < hi, np.minimum(found, first), found)
    return found


def _first_past(clocks: np.ndarray, stamp: np.ndarray, wait_s: float) -> np.ndarray:
    """:func:`first_expired` in one rising run of clocks, from its start."""
    size = clocks.size
    first = np.searchsorted(clocks, stamp + wait_s, side="right")
    before = np.maximum(first - 1, 0)
    back = (first > 0) & (clocks[before] - stamp > wait_s)
    first = np.where(back, np.searchsorted(clocks, clocks[before], side="left"), first)
    at = np.minimum(first, size - 1)
    on = (first < size) & ~(clocks[at] - stamp > wait_s)
    return np.where(on, np.searchsorted(clocks, clocks[at], side="right"), first)


def oblateness_model(u_rad, altitude_m, inclination_rad):
    """The published closed form (physics.md §2.1) where the orbit is known, NaN elsewhere: (roll, pitch), rad.

    ``(N,)`` arrays (a segment's samples).
    """
    known = np.isfinite(u_rad) & np.isfinite(inclination_rad) & (altitude_m > 0.0) & (altitude_m < np.inf)
    # An absurd but finite altitude (an orbit column of 1e308 m) overflows to a model of 0: no warning for it.
    with np.errstate(over="ignore"):
        if known.all():  # the orbit of every sample (a node's odometry is fresh): no gaps to keep
            _, roll, pitch = closed_form_oblateness(u_rad, altitude_m, inclination_rad)
            return roll, pitch
        roll, pitch = np.full(u_rad.shape, np.nan), np.full(u_rad.shape, np.nan)
        if known.any():
            _, roll[known], pitch[known] = closed_form_oblateness(u_rad[known], altitude_m[known],
                                                                  inclination_rad[known])
    return roll, pitch


class Alignment:
    """The truth buffer and the pending queue between inputs, and the array alignment of a segment."""

    def __init__(self, config) -> None:
        self.config = config
        self.clear()

    def clear(self) -> None:
        """Drop truth and the queue (a new time axis); the caller settles what was waiting first."""
        self.truth = np.empty((3, 0))  # stamp, roll, pitch, in arrival order
        self.truth_pruned = False  # something was pruned since the (re)start: NO_TRUTH becomes TOO_OLD
        self._wait(np.empty((len(SAMPLE_ROWS), 0)))
        self._indexed = False  # the queue holds places in the current input

    @property
    def truth_count(self) -> int:
        """Truth samples held."""
        return self.truth.shape[1]

    def _wait(self, pending: np.ndarray) -> None:
        """The samples waiting from now on, ``(7, k)``: :data:`SAMPLE_ROWS`, oldest first (their count and the oldest
        stamp kept as plain numbers for the scan)."""
        self.pending = pending
        self.pending_count = pending.shape[1]
        self.oldest_pending_s = float(pending[1, 0]) if self.pending_count else math.inf

    def take_pending(self) -> Settled:
        """Every waiting sample as settled by a reset (RESET), and an empty queue."""
        p = self.pending
        n = p.shape[1]
        nan = np.full(n, np.nan)
        settled = Settled(np.vstack((p[0], p[1], np.full(n, float(_RESET)), nan, nan, p[4], p[5], p[6])))
        self._wait(p[:, :0])
        return settled

    def forget_indices(self) -> None:
        """The samples still waiting belong to an earlier input from now on."""
        if self._indexed:
            self.pending[0] = -1.0
            self._indexed = False

    def settle(self, segment: Segment) -> Settled:
        """Settle a segment: every sensor sample's fate (or its wait), the buffer and queue it leaves.

        One path for any segment, a node's message of one sample as a campaign's orbit; what cannot happen in it
        (a sample settled on arrival, a timeout, an overflow, a pruned buffer) is skipped after a scalar test, not
        computed as nothing.
        """
        config = self.config
        events = segment.expiry_clock_s.size
        samples = segment.samples
        # Refused samples and those with neither angle settle on arrival; the others are candidates.
        own = segment.sensor_code != PENDING_CODE if segment.on_arrival else None
        prior = self.pending.shape[1]
        if own is None:
            candidates = np.concatenate((self.pending, samples), axis=1) if prior else samples
            arrive = segment.sensor_event
        else:
            valid = ~own
            candidates = np.concatenate((self.pending, samples[:, valid]), axis=1)
            arrive = segment.sensor_event[valid]
        if prior:  # waiting from before: arrival −1; stamps rising
            arrive = np.concatenate((np.full(prior, -1, np.int64), arrive))
        stamp = candidates[1]
        count = stamp.size
        # Truth: the buffer (arrived before: event −1), then this segment's accepted samples.
        held = self.truth.shape[1]
        new_truth = segment.truth.shape[1]
        truth = np.concatenate((self.truth, segment.truth), axis=1) if new_truth else self.truth
        truth_t = truth[0]
        truth_event = np.concatenate((np.full(held, -1, np.int64), segment.truth_event)) if held else \
            segment.truth_event
        total = truth_t.size
        # When each candidate settles: at once, when truth covers it, when its wait runs out, or never here.
        hi = np.searchsorted(truth_t, stamp, side="left")  # the first truth at or after the stamp
        covered = hi < total
        cover = np.where(covered, truth_event[np.minimum(hi, total - 1)] if total else 0, events)
        at_once = covered & (cover < arrive)
        clocks, wait_s = segment.expiry_clock_s, config.max_truth_wait_s
        stale = expire = None  # float subtraction is monotone: no clock past the oldest stamp, no timeout
        if events and count and clocks.max() - stamp.min() > wait_s:
            expire = first_expired(clocks, stamp, wait_s, np.maximum(arrive, 0))
            stale = ~at_once & (expire < cover)  # at a truth event, what it covers is aligned before the timeout
            if not stale.any():
                stale = None
        settle = np.where(at_once, arrive, cover if stale is None else np.minimum(cover, expire))  # events: waiting
        # The queue (candidates not aligned on arrival), FIFO: the sample max_pending places ahead of an
        # arrival is pushed out if it is still there — a stale one timed out at that event is (timeouts
        # come after the push).
        queued = np.flatnonzero(~at_once)
        limit = config.max_pending
        overflow = None
        if queued.size > limit:
            pushed, pusher = queued[:-limit], queued[limit:]
            out = settle[pushed] >= arrive[pusher]
            overflow = np.zeros(count, bool)
            overflow[pushed[out]] = True
            settle[pushed[out]] = arrive[pusher[out]]
        queue_settle = settle[queued]
        # Without a timeout or an overflow the queue settles by cover, which rises with the stamps.
        if (stale is not None or overflow is not None) and queued.size > 1 and (
                queue_settle[1:] < queue_settle[:-1]).any():
            raise RuntimeError("monitor alignment: the queue would not settle in order (stamps not increasing)")
        # The buffer's first sample after each truth event (prune: history, the oldest waiting sample, capacity);
        # it only moves forward.
        start_after = None
        if new_truth:
            event = segment.truth_event
            front = np.searchsorted(queue_settle, event, side="right")  # the first not settled by then
            front_stamp = np.inf
            if queued.size:
                fronts = queued[np.minimum(front, queued.size - 1)]
                front_stamp = np.where((front < queued.size) & (arrive[fronts] < event), stamp[fronts], np.inf)
            cutoff = np.minimum(truth[0, held:] - config.truth_history_s, front_stamp)
            drop = np.maximum(np.searchsorted(truth_t, cutoff, side="right") - 1,
                              np.arange(held + 1 - config.truth_capacity, total + 1 - config.truth_capacity))
            drop = np.maximum.accumulate(np.maximum(drop, 0))
            if drop[-1] > 0:
                start_after = np.concatenate((np.zeros(held, np.int64), drop))
        # The buffer each aligned sample sees: as left by the truth event before its settle event.
        aligned = settle < events
        if stale is not None:
            aligned &= ~stale
        if overflow is not None:
            aligned &= ~overflow
        at = np.minimum(hi, max(total - 1, 0))
        exact = covered & (truth_t[at] == stamp) if total else covered
        low = np.maximum(hi - 1, 0)
        if start_after is None:  # nothing pruned in this segment: each sees the buffer from its start
            pruned, lost, first = self.truth_pruned, None, ~exact & (hi == 0)
        else:
            seen = np.where(at_once, np.searchsorted(truth_event, arrive, side="left") - 1, hi - 1)
            start = np.where(seen >= 0, start_after[np.maximum(seen, 0)], 0)
            pruned = self.truth_pruned | (start > 0)
            lost = hi < start  # the covering truth itself was pruned: all the buffer is later
            first = ~lost & ~exact & (hi == start)  # nothing before the stamp in the buffer
        kept = ~first if lost is None else ~lost & ~first
        gap = kept & ~exact & (truth_t[at] - truth_t[low] > config.max_truth_gap_s) if total else covered
        used = aligned & kept & ~gap
        # In settle order: per event, the sample's own fate (or what a truth pops), pushed out, timed out.
        done = settle < events
        block = np.empty((len(SETTLED_ROWS), count))
        block[0:2] = candidates[0:2]
        if pruned is True:
            block[2] = np.where(used, _OK, np.where(aligned & gap, _GAP, _TOO_OLD))
        else:
            block[2] = np.where(used, _OK, np.where(aligned & gap, _GAP, np.where(pruned, _TOO_OLD, _NO_TRUTH)))
        if stale is not None:
            block[2] = np.where(stale, _STALE_CODE, block[2])
        if overflow is not None:
            block[2] = np.where(overflow, _OVERFLOW_CODE, block[2])
        block[3:5] = np.nan
        k = np.flatnonzero(used)
        if k.size:
            h, lo, hit = hi[k], low[k], exact[k]
            weight = (stamp[k] - truth_t[lo]) / np.where(hit, 1.0, truth_t[h] - truth_t[lo])
            at_truth = np.where(hit, truth[1:3, h], truth[1:3, lo] + weight * (truth[1:3, h] - truth[1:3, lo]))
            block[3:5, k] = candidates[2:4, k] - at_truth
        block[5:8] = candidates[4:7]
        # What stays: the buffer as the last truth event left it, and the samples still waiting.
        if start_after is not None:
            keep = start_after[-1]
            self.truth = truth[:, keep:]
            self.truth_pruned = True
        elif new_truth:
            self.truth = truth
        all_done = bool(done.all())
        self._wait(candidates[:, :0] if all_done else candidates[:, ~done])
        self._indexed = True
        if not all_done:
            block = block[:, done]
        if own is None:
            if stale is not None or overflow is not None:
                block = block[:, np.argsort((settle * 3 + _phase(stale, overflow))[done], kind="stable")]
            return Settled(block)
        immediate = np.flatnonzero(own)
        first_block = np.empty((len(SETTLED_ROWS), immediate.size))
        first_block[0:2] = samples[0:2, immediate]
        first_block[2] = segment.sensor_code[immediate]
        first_block[3:5] = np.nan
        first_block[5:8] = samples[4:7, immediate]
        key = np.concatenate((segment.sensor_event[immediate] * 3 + _OWN, (settle * 3 + _phase(stale, overflow))[done]))
        return Settled(np.concatenate((first_block, block), axis=1)[:, np.argsort(key, kind="stable")])


def _phase(stale, overflow):
    """Where in its settle event each candidate goes: its own fate, then pushed out, then timed out."""
    phase = _OWN if stale is None else np.where(stale, _STALE, _OWN)
    return phase if overflow is None else np.where(overflow, _OVERFLOW, phase)
