"""The published flight-test procedure of physics.md §5 (steps 1–5), with the harmonics of §5.1 per
complete orbit: :func:`flight_test_statistics` on telemetry of roll and pitch against a reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..physics.instrument.oblateness import closed_form_oblateness
from .statistics import (MAX_NOISE_GAIN, ORBIT_HARMONICS, TWO_PI, ChannelStatistics, RunningStatistics,
                         harmonic_amplitudes)


def correct_reference_drift(values_rad, elapsed_s, drift_rate_rad_s: float):
    """Remove a reference drift that grows linearly since its last correction (physics.md §5, step 1).

    Args:
        values_rad: measured angles against the drifting reference, rad.
        elapsed_s: time since the reference was last corrected (e.g. since the
            start of the orbit for a gyro reset once an orbit by the star tracker), s.
        drift_rate_rad_s: known drift rate of the reference, rad/s.
    """
    return np.asarray(values_rad, float) - drift_rate_rad_s * np.asarray(elapsed_s, float)


#: Resolution of the orbital angle in step 2, rad: exact u is grouped to it, and no u bin is narrower (a bin
#: far below it would only split equal angles, and near 0 its index would overflow).
U_RESOLUTION_RAD = 1e-9


def average_over_orbits(u_rad, values, bin_rad: float | None = None):
    """Average samples taken at the same orbital angle over the orbits (physics.md §5, step 2).

    Args:
        u_rad: ``(N,)`` argument of latitude of each sample, rad (any number of orbits).
        values: ``(N,)`` or ``(N, C)`` samples.
        bin_rad: None to group samples with the same u (to
            :data:`U_RESOLUTION_RAD`), as in the published telemetry sampled
            on a fixed grid of u; otherwise the width of the u bins, rad, for
            telemetry sampled in time: :data:`U_RESOLUTION_RAD` … 2π.

    Returns:
        (u_rad ``(G,)`` in [0, 2π) — the mean u of each group, sorted;
        means ``(G,)`` or ``(G, C)``; counts ``(G,)``).
    """
    u = np.mod(np.asarray(u_rad, float).ravel(), TWO_PI)
    data = np.asarray(values, float)
    single = data.ndim == 1
    data = data.reshape(u.size, -1)
    if bin_rad is None:
        scale = 1.0 / U_RESOLUTION_RAD
        keys = np.round(u * scale).astype(np.int64) % int(round(TWO_PI * scale))
    else:
        if not (math.isfinite(bin_rad) and U_RESOLUTION_RAD <= bin_rad <= TWO_PI):
            raise ValueError(f"u bin width = {bin_rad} rad is outside the allowed range [{U_RESOLUTION_RAD:g}, 2π]")
        keys = np.floor(u / bin_rad).astype(np.int64)
    groups, first, inverse, counts = np.unique(keys, return_index=True, return_inverse=True, return_counts=True)
    sums = np.zeros((groups.size, data.shape[1]))
    np.add.at(sums, inverse, data)
    # Mean of u about the group's first member, so a group straddling 0/2π stays whole.
    anchor = u[first]
    u_sums = np.zeros(groups.size)
    np.add.at(u_sums, inverse, np.angle(np.exp(1j * (u - anchor[inverse]))))
    group_u = np.mod(anchor + u_sums / counts, TWO_PI)
    # A group at u = 0 whose members straddle the wrap sorts first, not last.
    group_u = np.where(group_u > TWO_PI - 1e-9, 0.0, group_u)
    means = sums / counts[:, None]
    order = np.argsort(group_u)
    means = means[order]
    return group_u[order], (means[:, 0] if single else means), counts[order]


#: The statistics channels, in the order of every table and of /pmv/error_statistics.
@dataclass(frozen=True)
class ChannelResult(ChannelStatistics):
    """Statistics of one channel of a flight-test analysis, rad, with its offset and both harmonic sets.

    ``offset_rad`` is the constant removed (K or T; 0 for meridional);
    ``harmonics_rad`` are the amplitudes after the offset and (when asked)
    oblateness removal; ``harmonics_with_oblateness_rad`` before the
    oblateness removal — where the oblateness shows (roll k = 1, pitch k = 2).
    Both are means over the complete orbits (``orbits_in_harmonics``).
    """

    offset_rad: float = math.nan
    harmonics_with_oblateness_rad: dict = field(default_factory=dict)
    orbits_in_harmonics: int = 0


@dataclass(frozen=True)
class FlightTestResult:
    """The outcome of the flight-test procedure (physics.md §5), rad.

    Per distinct orbital angle u (step 2): the orbit-averaged roll and pitch,
    the oblateness model, the residuals δβ_k, δβ_t and the meridional
    residual δβ_m. Then the offsets K, T (step 3), MO, σ_m and the limits
    MO ± 3σ_m (step 5), and per-channel detail with the harmonics of §5.1.
    """

    u_rad: np.ndarray
    samples_per_u: np.ndarray
    roll_mean_rad: np.ndarray
    pitch_mean_rad: np.ndarray
    oblateness_roll_rad: np.ndarray
    oblateness_pitch_rad: np.ndarray
    roll_residual_rad: np.ndarray
    pitch_residual_rad: np.ndarray
    meridional_rad: np.ndarray
    roll_offset_rad: float
    pitch_offset_rad: float
    mo_rad: float
    sigma_m_rad: float
    oblateness_removed: bool
    orbits: int
    channels: tuple = ()

    @property
    def limit_low_rad(self) -> float:
        """MO − 3σ_m."""
        return self.mo_rad - 3.0 * self.sigma_m_rad

    @property
    def limit_high_rad(self) -> float:
        """MO + 3σ_m — the limit methodical error the flight analysis quotes (≈ 8′ for Kondor)."""
        return self.mo_rad + 3.0 * self.sigma_m_rad

    def channel(self, name: str) -> ChannelResult:
        """The detail of channel ``name`` (roll, pitch or meridional)."""
        for result in self.channels:
            if result.channel == name:
                return result
        raise KeyError(name)


def fewest_samples() -> int:
    """Fewest samples an orbit needs for :func:`harmonic_amplitudes` to resolve anything.

    n distinct orbital angles resolve harmonics up to k = (n − 1)//2 (the
    Nyquist limit of :func:`~pmv_ros.analysis.statistics.fit_harmonics`), so an
    orbit with fewer than 3 samples gives only NaN, and is not fitted at all.
    """
    return 3


def _orbit_members(orbits: np.ndarray, fewest: int):
    """The sample indices of each orbit with at least ``fewest`` samples, in orbit order, each in sample order.

    One stable sort of the orbit numbers, O(N log N) whatever the number of
    orbits (a mask per orbit would be O(N × orbits): quadratic for telemetry
    with one orbit per row).
    """
    order = np.argsort(orbits, kind="stable")
    _, starts, counts = np.unique(orbits[order], return_index=True, return_counts=True)
    for start, count in zip(starts[counts >= fewest].tolist(), counts[counts >= fewest].tolist()):
        yield order[start:start + count]


def flight_test_statistics(u_rad, roll_rad, pitch_rad, altitude_m: float, inclination_rad: float, *,
                           orbit_index=None, remove_oblateness: bool = True, u_bin_rad: float | None = None,
                           harmonics=ORBIT_HARMONICS, max_noise_gain: float = MAX_NOISE_GAIN) -> FlightTestResult:
    """The published flight-test statistics of the sensor error (physics.md §5, steps 2–5, and §5.1).

    Step 1 (reference drift) is the caller's: see :func:`correct_reference_drift`.

    2. average roll β_k(u) and pitch β_t(u) over the orbits at each u
       (:func:`average_over_orbits`);
    3. K = mean of the averaged roll, T = mean of the averaged pitch (each u
       weighs the same, so uneven coverage of the orbit does not bias them);
       Δβ = β − offset;
    4. δβ_k = Δβ_k − (Δβ)_roll(u), δβ_t = Δβ_t − (Δβ)_pitch(u), the published
       closed-form oblateness model (physics.md §2.1;
       :func:`pmv_ros.physics.instrument.oblateness.closed_form_oblateness`) in REP-103 like
       the roll and pitch given here (published telemetry is converted first,
       :func:`pmv_ros.physics.conventions.convert`), averaged over
       the same samples as the data. Skipped when ``remove_oblateness`` is False;
    5. δβ_m = √(δβ_k² + δβ_t²); MO = its mean; σ_m with N − 1; limit MO ± 3σ_m.

    The harmonics (§5.1) are fitted to each complete orbit of the samples as
    given (not orbit-averaged, which would wash out features that do not
    repeat from orbit to orbit, such as weather) after subtracting K, T and
    the oblateness model, and averaged over the complete orbits.

    Cost, N samples in any number of orbits: O(N log N) time (two sorts: the
    orbital angles of step 2 and the orbit numbers of §5.1) and O(N) memory
    (≈ 0.2 kB a sample at the peak). An orbit with fewer samples than
    :func:`fewest_samples` cannot resolve a harmonic and is not fitted, so at
    most N/3 least-squares fits run, each linear in its samples: telemetry
    of one orbit per row costs what any other layout of the same N does.

    Args:
        u_rad: ``(N,)`` argument of latitude of each sample, rad (unwrapped or
            not; with ``orbit_index`` None, the orbit of a sample is ⌊u/2π⌋).
        roll_rad, pitch_rad: ``(N,)`` sensor error against the reference, rad, REP-103.
        altitude_m: orbit altitude H above the mean radius, m (oblateness model).
        inclination_rad: orbit inclination, rad (oblateness model).
        orbit_index: ``(N,)`` orbit number of each sample, or None.
        remove_oblateness: apply step 4.
        u_bin_rad: width of the u bins of step 2, rad; None for exact u.
        harmonics, max_noise_gain: see :func:`~pmv_ros.analysis.statistics.fit_harmonics`.
    """
    u = np.asarray(u_rad, float).ravel()
    roll = np.asarray(roll_rad, float).ravel()
    pitch = np.asarray(pitch_rad, float).ravel()
    if not (u.size == roll.size == pitch.size):
        raise ValueError(f"u, roll and pitch must have the same length, got {u.size}, {roll.size}, {pitch.size}")
    keep = np.isfinite(u) & np.isfinite(roll) & np.isfinite(pitch)
    orbits = np.floor(u / TWO_PI).astype(np.int64) if orbit_index is None else np.asarray(orbit_index).ravel()
    if orbits.size != u.size:
        raise ValueError(f"orbit_index has {orbits.size} entries for {u.size} samples")
    u, roll, pitch, orbits = u[keep], roll[keep], pitch[keep], orbits[keep]

    _, model_roll, model_pitch = closed_form_oblateness(u, altitude_m, inclination_rad)
    if not remove_oblateness:
        model_roll, model_pitch = np.zeros_like(u), np.zeros_like(u)
    group_u, means, counts = average_over_orbits(u, np.column_stack([roll, pitch, model_roll, model_pitch]),
                                                 u_bin_rad)
    if group_u.size < 2:
        raise ValueError(f"need samples at 2 or more distinct orbital angles, got {group_u.size}")
    roll_mean, pitch_mean, obl_roll, obl_pitch = means.T
    roll_offset, pitch_offset = float(roll_mean.mean()), float(pitch_mean.mean())
    roll_residual = roll_mean - roll_offset - obl_roll
    pitch_residual = pitch_mean - pitch_offset - obl_pitch
    meridional = np.hypot(roll_residual, pitch_residual)

    # §5.1 on each complete orbit of the samples as given.
    per_sample = np.column_stack([roll - roll_offset - model_roll, pitch - pitch_offset - model_pitch])
    per_sample = np.column_stack([per_sample, np.hypot(per_sample[:, 0], per_sample[:, 1]),
                                  roll - roll_offset, pitch - pitch_offset,
                                  np.hypot(roll - roll_offset, pitch - pitch_offset)])
    per_orbit = []
    for members in _orbit_members(orbits, fewest_samples()):
        amplitudes = harmonic_amplitudes(u[members], per_sample[members], harmonics, max_noise_gain=max_noise_gain)
        if np.isfinite(amplitudes[0]).any():
            per_orbit.append(amplitudes)
    if per_orbit:
        # Amplitudes a harmonic cannot be resolved at stay NaN (nanmean of all-NaN warns; avoid it).
        stack = np.array(per_orbit)
        resolved = np.isfinite(stack).all(axis=0)
        mean_amplitude = np.where(resolved, np.where(resolved, stack, 0.0).mean(axis=0), np.nan)
    else:
        mean_amplitude = np.full((len(harmonics), per_sample.shape[1]), np.nan)

    def table(column):
        return {int(k): float(a) for k, a in zip(harmonics, mean_amplitude[:, column])}

    channels = []
    for name, offset, series, column, raw_column in (("roll", roll_offset, roll_residual, 0, 3),
                                                     ("pitch", pitch_offset, pitch_residual, 1, 4),
                                                     ("meridional", 0.0, meridional, 2, 5)):
        stats = RunningStatistics()
        stats.update(series)
        channels.append(ChannelResult(name, stats.count, stats.mean, stats.sigma, stats.max_abs, table(column),
                                      offset_rad=offset, harmonics_with_oblateness_rad=table(raw_column),
                                      orbits_in_harmonics=len(per_orbit)))
    merid_stats = channels[2]
    return FlightTestResult(
        u_rad=group_u, samples_per_u=counts, roll_mean_rad=roll_mean, pitch_mean_rad=pitch_mean,
        oblateness_roll_rad=obl_roll, oblateness_pitch_rad=obl_pitch, roll_residual_rad=roll_residual,
        pitch_residual_rad=pitch_residual, meridional_rad=meridional, roll_offset_rad=roll_offset,
        pitch_offset_rad=pitch_offset, mo_rad=merid_stats.mean_rad, sigma_m_rad=merid_stats.sigma_rad,
        oblateness_removed=bool(remove_oblateness), orbits=int(np.unique(orbits).size), channels=tuple(channels))
