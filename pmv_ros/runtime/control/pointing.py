"""The true pointing error of a closed loop: the body's roll and pitch from the true attitude, as statistics.

The one home of the figure an attitude-control engineer asks for first (issue "the closed loop"): with
the PMV in the loop, where does the body point? The target is nadir pointing (roll = pitch = 0 in the
orbital frame, REP-103), so the error is the body's true roll and pitch
(:func:`pmv_ros.physics.attitude.true_roll_pitch`). Per axis: count, mean, σ, max |e| and the harmonics
of the orbital frequency (physics.md §5.1) — the same record and the same statistics code as the
monitor's residuals (:class:`~pmv_ros.analysis.statistics.ChannelStatistics`,
:class:`~pmv_ros.analysis.statistics.RunningStatistics`,
:func:`~pmv_ros.analysis.statistics.harmonic_amplitudes`), so the two stand side by side in a report.

The controller's start-up transient is not the pointing error of the loop: samples before
``skip_until_s`` (the caller passes the loop's settling time) are left out and counted.
Memory is bounded: a decimated series (for the plot and the harmonic fit) of at most ``max_points``.
"""

from __future__ import annotations

import math

import numpy as np

from ...analysis.statistics import ORBIT_HARMONICS, ChannelStatistics, RunningStatistics, harmonic_amplitudes
from ...physics.attitude import true_roll_pitch

#: The axes of the pointing error (the channels of :class:`ChannelStatistics` it fills).
AXES = ("roll", "pitch")


class PointingStatistics:
    """Running statistics of the true roll and pitch after ``skip_until_s``, with a bounded series.

    Args:
        period_s: the orbital period, s (the harmonics are of 1/period).
        skip_until_s: samples stamped before this are the transient: counted in :attr:`skipped`, not used.
        max_points: most samples the series keeps (every 2nd, 4th, … once full).
    """

    def __init__(self, period_s: float, skip_until_s: float, max_points: int = 50_000) -> None:
        if not (math.isfinite(period_s) and period_s > 0.0):
            raise ValueError(f"period_s = {period_s} must be a positive number of seconds")
        if max_points < 2:
            raise ValueError(f"max_points = {max_points} must be at least 2")
        self.period_s = float(period_s)
        self.skip_until_s = float(skip_until_s)
        self.max_points = int(max_points)
        self.roll, self.pitch = RunningStatistics(), RunningStatistics()
        self.skipped = 0
        self._series = []  # (t_s, roll_rad, pitch_rad), every ``_stride``-th used sample
        self._stride, self._seen = 1, 0

    def add(self, t_s: float, q_xyzw) -> tuple[float, float]:
        """One true attitude (x, y, z, w) at ``t_s``; returns its (roll, pitch), rad (also before ``skip_until_s``)."""
        roll, pitch = true_roll_pitch(q_xyzw)
        if t_s < self.skip_until_s:
            self.skipped += 1
            return roll, pitch
        self.roll.add(roll)
        self.pitch.add(pitch)
        self._keep(t_s, roll, pitch)
        return roll, pitch

    def add_many(self, t_s, q_xyzw) -> None:
        """True attitudes ``(4, N)`` at increasing times ``(N,)``: as N calls of :meth:`add`."""
        t = np.asarray(t_s, float)
        roll, pitch = true_roll_pitch(np.asarray(q_xyzw, float).reshape(4, -1))
        used = t >= self.skip_until_s
        self.skipped += int(t.size - used.sum())
        self.roll.update(roll[used])
        self.pitch.update(pitch[used])
        for stamp, r, p in zip(t[used].tolist(), roll[used].tolist(), pitch[used].tolist()):
            self._keep(stamp, r, p)

    def _keep(self, t_s: float, roll: float, pitch: float) -> None:
        self._seen += 1
        if self._seen % self._stride:
            return
        self._series.append((t_s, roll, pitch))
        if len(self._series) >= self.max_points:  # halve the resolution: bounded for any run length
            self._series = self._series[::2]
            self._stride *= 2

    def series(self) -> np.ndarray:
        """``(3, N)``: stamp (s), true roll and pitch (rad) of the kept samples."""
        return np.array(self._series, float).T.reshape(3, -1)

    def channels(self, harmonics=ORBIT_HARMONICS) -> tuple[ChannelStatistics, ChannelStatistics]:
        """Roll and pitch as :class:`ChannelStatistics` (rad): count, mean, σ, max |e| of every used sample; the
        harmonics fitted to the kept series (NaN when it does not cover an orbit: the fit's gap rule)."""
        t, roll, pitch = self.series()
        phase = 2.0 * math.pi * t / self.period_s
        amplitudes = harmonic_amplitudes(phase, np.stack([roll, pitch], axis=1), harmonics) if t.size else \
            np.full((len(harmonics), 2), np.nan)
        return tuple(ChannelStatistics(axis, count=stats.count, mean_rad=stats.mean, sigma_rad=stats.sigma,
                                       max_abs_rad=stats.max_abs,
                                       harmonics_rad={k: float(a) for k, a in zip(harmonics, amplitudes[:, i])})
                     for i, (axis, stats) in enumerate(zip(AXES, (self.roll, self.pitch))))
