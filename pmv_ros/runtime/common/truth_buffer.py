"""The attitude a following sensor measures with: truth at its own sample time, or none.

A sensor in follow mode samples at its own times, the user's attitude stack
publishes truth at its own. :class:`TruthBuffer` keeps the last samples of
truth and answers "what was the attitude at t?":

* between two samples: the constant-rate turn between them (slerp,
  :func:`pmv_ros.physics.attitude.slerp`), unless they are further apart than
  ``max_gap_s`` — nothing is interpolated across a gap;
* beyond the newest: the last body rate carried on — for
  ``extrapolation_periods`` truth periods (the interval of the last two
  samples) as a matter of course (EXTRAPOLATED), and further, up to
  ``bridge_s`` seconds past the newest, to bridge a late truth sample — a
  scheduler hiccup of the user's stack (BRIDGED, which the sensor counts);
  never more than ``max_gap_s``. Later than that the truth is stale and
  there is no attitude — the sensor publishes nothing rather than an angle
  from an attitude nobody gave it.

Why a horizon in seconds as well as in periods: the hiccup of a busy host is
a fixed time (tens to hundreds of ms), whatever the truth rate; two periods
of 50 Hz truth (40 ms) are shorter than one. Carrying the last rate on for
0.3 s costs ½·α·t² for an angular acceleration α the truth did not show:
0.03′ at 0.01°/s², a brisk manoeuvre for an Earth-pointing spacecraft — well
under the instrument's own error (arcminutes).

Memory is bounded (``capacity`` samples); stamps are taken in increasing
order (the caller validates them; a stamp at or before the newest clears
the buffer: a new timeline).
"""

from __future__ import annotations

import bisect
import enum
from collections import deque

from ...physics.attitude import slerp


class TruthAt(str, enum.Enum):
    """Where the attitude for a sample time came from, or why there is none (value: the counter name)."""

    INTERPOLATED = "interpolated"  #: between two samples (or at one)
    EXTRAPOLATED = "extrapolated"  #: past the newest, within extrapolation_periods truth periods
    BRIDGED = "bridged"            #: past the newest by more than that, within bridge_s: a late truth sample
    NO_TRUTH = "no_truth"          #: nothing yet to measure with (no sample, or one sample and no rate)
    TOO_OLD = "too_old"            #: before the oldest sample kept
    TRUTH_GAP = "truth_gap"        #: the bracketing samples are further apart than max_gap_s
    STALE = "stale"                #: past the newest by more than the extrapolation horizon

    @property
    def usable(self) -> bool:
        """An attitude is given."""
        return self in (TruthAt.INTERPOLATED, TruthAt.EXTRAPOLATED, TruthAt.BRIDGED)


#: Default of ``bridge_s`` (and of the sensor's ``attitude.extrapolation_s``): a truth sample ≈ 0.25 s late
#: at any truth rate is bridged (the module docstring says why this much).
DEFAULT_BRIDGE_S = 0.3

#: Samples kept: 5 s of truth at 50 Hz; a following sensor samples within the last few.
DEFAULT_CAPACITY = 256

#: Stamps this close (s) are the same instant (float stamps from integer nanoseconds).
_SAME_INSTANT_S = 1e-9


class TruthBuffer:
    """The last ``capacity`` truth samples and the attitude at any time they cover.

    Args:
        extrapolation_periods: how far past the newest sample the last body
            rate is carried as a matter of course, in truth periods (the interval of the last two samples).
        bridge_s: how far past the newest sample, s, the last body rate is carried at most (a late sample).
        max_gap_s: no interpolation across, and no extrapolation beyond, this many seconds.
        capacity: samples kept.
    """

    def __init__(self, extrapolation_periods: float = 2.0, max_gap_s: float = 1.0,
                 capacity: int = DEFAULT_CAPACITY, bridge_s: float = DEFAULT_BRIDGE_S):
        if not (0.0 <= extrapolation_periods <= 100.0):
            raise ValueError(f"extrapolation_periods = {extrapolation_periods} is outside the allowed range 0 … 100")
        if not (0.0 <= bridge_s <= 3600.0):
            raise ValueError(f"bridge_s = {bridge_s} s is outside the allowed range 0 … 3600 s")
        self.bridge_s = float(bridge_s)
        if not (max_gap_s > 0.0):
            raise ValueError(f"max_gap_s = {max_gap_s} must be > 0 s")
        self.extrapolation_periods = float(extrapolation_periods)
        self.max_gap_s = float(max_gap_s)
        self._stamps = deque(maxlen=capacity)
        self._attitudes = deque(maxlen=capacity)

    def __len__(self) -> int:
        return len(self._stamps)

    @property
    def newest_stamp_s(self) -> float | None:
        """Stamp of the newest sample, s (None when empty)."""
        return self._stamps[-1] if self._stamps else None

    def clear(self) -> None:
        """Forget every sample."""
        self._stamps.clear()
        self._attitudes.clear()

    def take_samples(self, other: "TruthBuffer") -> None:
        """Keep the samples of ``other`` (a buffer reconfigured while truth keeps coming)."""
        self._stamps.extend(other._stamps)
        self._attitudes.extend(other._attitudes)

    def add(self, t_s: float, q_xyzw: tuple) -> None:
        """Keep one sample: stamp (s) and unit quaternion (x, y, z, w), a tuple of Python floats as
        :func:`~pmv_ros.runtime.common.validation.check_quaternion_sample` gives it (kept as it is: the attitude
        this buffer gives at that instant). A stamp not after the newest starts over."""
        stamps = self._stamps
        if stamps and t_s <= stamps[-1]:
            self.clear()
        stamps.append(float(t_s))
        self._attitudes.append(q_xyzw)

    def _routine_horizon_s(self) -> float:
        """How far past the newest sample extrapolation is routine, s: extrapolation_periods truth periods."""
        return self.extrapolation_periods * (self._stamps[-1] - self._stamps[-2])

    def horizon_s(self) -> float:
        """How far past the newest sample an attitude is still given, s (0 with fewer than two samples,
        or when the last two are further apart than ``max_gap_s``): the longer of extrapolation_periods
        truth periods and ``bridge_s``, never beyond ``max_gap_s``."""
        if len(self._stamps) < 2 or self._stamps[-1] - self._stamps[-2] > self.max_gap_s:
            return 0.0
        return min(max(self._routine_horizon_s(), self.bridge_s), self.max_gap_s)

    def attitude_at(self, t_s: float) -> tuple[tuple | None, TruthAt]:
        """The attitude (x, y, z, w) at ``t_s`` and where it came from; (None, reason) when there is none."""
        stamps, attitudes = self._stamps, self._attitudes
        if not stamps:
            return None, TruthAt.NO_TRUTH
        newest = stamps[-1]
        if abs(t_s - newest) <= _SAME_INSTANT_S:
            return attitudes[-1], TruthAt.INTERPOLATED
        if t_s > newest:
            if len(stamps) < 2:
                return None, TruthAt.NO_TRUTH
            if newest - stamps[-2] > self.max_gap_s:  # the last rate would be taken across a gap
                return None, TruthAt.TRUTH_GAP
            if t_s - newest > self.horizon_s():
                return None, TruthAt.STALE
            (q,), _ = slerp(stamps[-2], attitudes[-2], newest, attitudes[-1], [t_s])
            return q, TruthAt.EXTRAPOLATED if t_s - newest <= self._routine_horizon_s() else TruthAt.BRIDGED
        if t_s < stamps[0] - _SAME_INSTANT_S:
            return None, TruthAt.TOO_OLD
        after = bisect.bisect_left(stamps, t_s)
        if abs(stamps[after] - t_s) <= _SAME_INSTANT_S:
            return attitudes[after], TruthAt.INTERPOLATED
        before = after - 1
        if stamps[after] - stamps[before] > self.max_gap_s:
            return None, TruthAt.TRUTH_GAP
        (q,), _ = slerp(stamps[before], attitudes[before], stamps[after], attitudes[after], [t_s])
        return q, TruthAt.INTERPOLATED


class PendingSamples:
    """Sample times of a following sensor waiting for the truth that covers them, in order.

    On a clock that steps by more than a period (or on the wall clock, where
    the truth of an instant arrives after it), the truth for a sample time
    often arrives after the tick that made the sample due. A due time waits
    here until truth covers it (then it is interpolated) or until the clock
    has moved on by the truth's horizon since the tick that made it due (then
    it takes what the buffer gives: extrapolated, bridged, or stale) — a
    clock that leapt a second ahead of the truth is not the truth being late.
    Memory is bounded by what one clock step and the horizon hold.
    """

    def __init__(self):
        self._times = deque()

    def __len__(self) -> int:
        return len(self._times)

    def clear(self) -> None:
        """Forget the waiting times (a new timeline)."""
        self._times.clear()

    def add(self, times, now_s: float) -> None:
        """Queue sample times, s (in order, after those queued), made due at clock reading ``now_s``."""
        self._times.extend((float(t), float(now_s)) for t in times)

    def ready(self, truth: TruthBuffer, now_s: float) -> list[tuple[float, tuple | None, TruthAt]]:
        """The queued times that can be measured at clock reading ``now_s``, in order, with the attitude and its
        source: each covered by truth, or waited for long enough since it was due — the longer of the
        buffer's horizon and its ``bridge_s``."""
        out, times = [], self._times
        wait_s = max(truth.horizon_s(), truth.bridge_s)
        while times:
            (t_s, due_s), newest = times[0], truth.newest_stamp_s
            covered = newest is not None and t_s <= newest + _SAME_INSTANT_S
            if not covered and now_s - due_s < wait_s:
                break
            times.popleft()
            out.append((t_s, *truth.attitude_at(t_s)))
        return out
