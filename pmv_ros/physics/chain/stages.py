"""The stages of the signal chain, and the general chain that runs them on a sampled profile.

physics.md §4, as named, ordered, pure stages (each usable and testable alone):

1. :func:`scan_nadir_angles` — the IFOV centre steps inwards from the scan start
   θ₀ at W = 2.46 °/ms in steps of dt = 0.01 ms;
2. :func:`ifov_energy` — the horizon profile convolved with the IFOV
   sensitivity (:func:`ifov_line_spread`, :func:`ifov_edge_response`);
3. :func:`detector_lag` — the first-order lag T_p, the Duhamel sum of §4 step 3;
4. :func:`comparator_times` — first crossings of J(1) = 0.33 J and J(2) = 0.67 J,
   linearly interpolated between steps;
5. :func:`gam_del` — Gam = t(1)·W, Del = (t(2) − t(1))·W;
6. :func:`brightness_correction` — POP = F(Del), Gam′ = Gam − POP (the table
   F itself lives in :mod:`pmv_ros.physics.instrument.correction`);
7. :func:`pair_angles` — β = ½(Gam(1) − Gam(2)) for a pair of opposite chords.

:func:`sense_sampled_chords` runs stages 1–6 on any radiance profile given as a
function of nadir angle (general, O(chords × scan samples × field)). The hot
path is :func:`pmv_ros.physics.chain.fast.sense_horizon_chords`.

IFOV sensitivity (the documented choice)
    A uniform circular field of full angle 2γ = 2.2°. Across the field the
    horizon is treated as straight (the limb is a small circle of radius
    φ₀ ≈ 68°; its curvature moves the limb by ≤ 0.25′ at the edge of the field,
    the same on every chord, so it cancels in β and in the rig table). The
    line-spread function along the scan is then the chord length of the disc,
    w(a) = 2/(πγ²)·√(γ² − a²), normalised so that a field filled with radiance
    B receives U = B (thresholds are absolute, in units of J).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..compiled import elementwise
from .parameters import DEFAULT_CHAIN_PARAMETERS, ChainParameters, DetectionStatus


# --------------------------------------------------------------------------------------------
# Stage 1: the scan
# --------------------------------------------------------------------------------------------

def scan_nadir_angles(scan_start_nadir_rad, params: ChainParameters = DEFAULT_CHAIN_PARAMETERS, steps=None):
    """Nadir angles θ_v = θ₀ − W·v·dt of the IFOV centre, rad (physics.md §4, step 1).

    Args:
        scan_start_nadir_rad: θ₀, rad, scalar or ``(N,)``.
        params: W, dt and the number of steps.
        steps: number of steps (default ``params.max_steps``).

    Returns:
        ``(steps,)`` or ``(N, steps)`` nadir angles, rad.
    """
    n = params.max_steps if steps is None else int(steps)
    theta0 = np.asarray(scan_start_nadir_rad, float)
    return theta0[..., None] - params.step_angle_rad * np.arange(n)


# --------------------------------------------------------------------------------------------
# Stage 2: the IFOV
# --------------------------------------------------------------------------------------------

def ifov_line_spread(offset_rad, params: ChainParameters = DEFAULT_CHAIN_PARAMETERS):
    """Line-spread function of the uniform circular field along the scan, 1/rad: 2/(πγ²)·√(γ² − a²).

    Args:
        offset_rad: offset a from the field centre along the scan, rad.
    """
    gamma = params.ifov_half_angle_rad
    a = np.asarray(offset_rad, float)
    return 2.0 / (math.pi * gamma**2) * np.sqrt(np.clip(gamma**2 - a**2, 0.0, None))


def _ifov_cumulative(offset_rad, gamma):
    """∫ from −γ to a of the line-spread function (the share of the field below offset a)."""
    z = np.clip(np.asarray(offset_rad, float) / gamma, -1.0, 1.0)
    return 0.5 + (np.arcsin(z) + z * np.sqrt(1.0 - z * z)) / math.pi


def _ifov_first_moment(offset_rad, gamma):
    """∫ from −γ to a of a·w(a) da, rad."""
    z = np.clip(np.asarray(offset_rad, float) / gamma, -1.0, 1.0)
    return -2.0 * gamma / (3.0 * math.pi) * (1.0 - z * z) ** 1.5


def ifov_edge_response(centre_inside_rad, params: ChainParameters = DEFAULT_CHAIN_PARAMETERS):
    """Share of the field beyond a straight edge when the field centre is ``u`` inside it (closed form).

    The energy a unit-radiance half-plane gives the uniform circular field:
    ½ + (asin z + z√(1 − z²))/π with z = u/γ (the circular-segment area).

    Args:
        centre_inside_rad: u, how far the field centre is past the edge into the bright side, rad.
    """
    return _ifov_cumulative(centre_inside_rad, params.ifov_half_angle_rad)


def _hat_kernel(spacing_rad, gamma):
    """Weights K_l = ∫ w(a)·hat(a/δ − l) da, exact: IFOV convolution of a piecewise-linear profile."""
    half = int(math.ceil(gamma / spacing_rad)) + 1
    l = np.arange(-half, half + 1, dtype=float)
    a = l * spacing_rad

    def segment(lo, hi):
        return (_ifov_cumulative(hi, gamma) - _ifov_cumulative(lo, gamma),
                _ifov_first_moment(hi, gamma) - _ifov_first_moment(lo, gamma))

    m0_left, m1_left = segment(a - spacing_rad, a)     # rising half of the hat
    m0_right, m1_right = segment(a, a + spacing_rad)   # falling half
    kernel = (m1_left / spacing_rad - (l - 1.0) * m0_left) + ((l + 1.0) * m0_right - m1_right / spacing_rad)
    return kernel, half


def ifov_energy(radiance_ru, sample_spacing_rad, params: ChainParameters = DEFAULT_CHAIN_PARAMETERS):
    """Energy U the field receives, r.u., at every sample of a finely sampled profile (physics.md §4, step 2).

    The profile is taken as piecewise linear between its samples and
    convolved exactly with the line-spread function (:func:`ifov_line_spread`).

    Args:
        radiance_ru: ``(..., L)`` radiance samples along the scan, r.u., at
            nadir angles decreasing by ``sample_spacing_rad`` (scan order).
        sample_spacing_rad: δ, rad.
        params: the field size.

    Returns:
        ``(..., L)`` energy with the field centred on each sample, r.u.
        (samples within γ of either end see zero radiance beyond the ends).
    """
    from scipy.signal import fftconvolve  # imported where used: the fast chain, what processes run, does without

    kernel, half = _hat_kernel(sample_spacing_rad, params.ifov_half_angle_rad)
    p = np.asarray(radiance_ru, float)
    padded = np.pad(p, [(0, 0)] * (p.ndim - 1) + [(half, half)])
    shape = (1,) * (p.ndim - 1) + (-1,)
    return fftconvolve(padded, kernel[::-1].reshape(shape), mode="valid", axes=-1)


# --------------------------------------------------------------------------------------------
# Stage 3: the detector lag
# --------------------------------------------------------------------------------------------

def detector_lag(energy_ru, params: ChainParameters = DEFAULT_CHAIN_PARAMETERS):
    """Detector output U_out at each step, r.u.: the first-order lag of physics.md §4, step 3.

    The Duhamel sum U_out(t_v) = Σ_{j≤v} dU_j·(1 − exp(−(t_v − t_j)/T_p)),
    dU_j = U_j − U_{j−1} (U_{−1} = 0: the detector is at rest before the scan)
    equals U_v − z_v with z_v = r·z_{v−1} + dU_v, r = exp(−dt/T_p): the same
    sum evaluated by recursion, O(steps) instead of O(steps²). As written, the
    sum holds each step's energy until the next step (dU_v enters with weight
    1 − exp(0) = 0 at t_v): even an instantaneous detector would read U_{v−1}
    at t_v. The calibration of T_p absorbs this half-step-on-average delay.

    Args:
        energy_ru: ``(..., steps)`` energy U_v at the scan steps, r.u.
        params: dt and T_p.
    """
    from scipy.signal import lfilter

    u = np.asarray(energy_ru, float)
    du = np.diff(u, axis=-1, prepend=0.0)
    z = lfilter([1.0], [1.0, -params.lag_decay_per_step], du, axis=-1)
    return u - z


# --------------------------------------------------------------------------------------------
# Stage 4: the comparators
# --------------------------------------------------------------------------------------------

def _interpolated_crossing(output, threshold):
    """Fractional step index of the first sample above ``threshold`` (linear interpolation), NaN if none."""
    above = output > threshold
    found = above.any(axis=-1)
    v = np.argmax(above, axis=-1)
    previous = np.take_along_axis(output, np.maximum(v - 1, 0)[..., None], axis=-1)[..., 0]
    current = np.take_along_axis(output, v[..., None], axis=-1)[..., 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        # v = 0 cannot cross after the detector starts at rest; guard it anyway.
        fraction = np.where(v > 0, (threshold - previous) / (current - previous), 0.0)
    return np.where(found, v - 1 + fraction + (v == 0), np.nan)


def comparator_times(output_ru, params: ChainParameters = DEFAULT_CHAIN_PARAMETERS):
    """First times t(1), t(2) at which the output exceeds J(1), J(2), s (physics.md §4, step 4).

    Linear interpolation between the last step at or below the threshold and
    the first step above it; time is counted from the scan start (step 0).

    Args:
        output_ru: ``(..., steps)`` detector output, r.u.

    Returns:
        (t1_s, t2_s, status): NaN times and a :class:`DetectionStatus` code where a
        threshold is never exceeded.
    """
    y = np.asarray(output_ru, float)
    t1 = _interpolated_crossing(y, params.threshold_1_ru) * params.time_step_s
    t2 = _interpolated_crossing(y, params.threshold_2_ru) * params.time_step_s
    status = np.where(np.isnan(t1), DetectionStatus.FIRST_THRESHOLD_NOT_REACHED,
                      np.where(np.isnan(t2), DetectionStatus.SECOND_THRESHOLD_NOT_REACHED, DetectionStatus.OK))
    t2 = np.where(np.isnan(t1), np.nan, t2)
    return t1, t2, status.astype(np.int8)


# --------------------------------------------------------------------------------------------
# Stages 5–7
# --------------------------------------------------------------------------------------------

@elementwise
def crossing_angle(t1_s, scan_rate_rad_s):
    """Gam = t(1)·W, rad, of one chord (the fast chain's kernel calls it; :func:`gam_del` on arrays)."""
    return t1_s * scan_rate_rad_s


@elementwise
def edge_slope(t1_s, t2_s, scan_rate_rad_s):
    """Del = (t(2) − t(1))·W, rad, of one chord (the fast chain's kernel calls it; :func:`gam_del` on arrays)."""
    return (t2_s - t1_s) * scan_rate_rad_s


def gam_del(t1_s, t2_s, params: ChainParameters = DEFAULT_CHAIN_PARAMETERS):
    """Gam = t(1)·W and Del = (t(2) − t(1))·W, rad (physics.md §4, step 5)."""
    return crossing_angle(t1_s, params.scan_rate_rad_s), edge_slope(t1_s, t2_s, params.scan_rate_rad_s)


def brightness_correction(del_rad, correction=None):
    """POP = F(Del), rad (physics.md §4, step 6); zero without a table.

    Args:
        del_rad: Del, rad.
        correction: a callable F mapping Del (rad) to POP (rad), e.g. a
            :class:`pmv_ros.physics.instrument.correction.CorrectionTable`; None for no table.
    """
    d = np.asarray(del_rad, float)
    if correction is None:
        return np.where(np.isnan(d), np.nan, 0.0)
    return np.asarray(correction(d), float)


def pair_angles(gam_1_rad, gam_2_rad):
    """β = ½(Gam(1) − Gam(2)), rad, for two opposite chords (physics.md §4, step 7).

    Pass Gam for β, Gam′ for β′. A brighter chord 2 crosses earlier, so β > 0 for B(1) < B(2).
    """
    return 0.5 * (np.asarray(gam_1_rad, float) - np.asarray(gam_2_rad, float))


@dataclass(frozen=True)
class ChordReadings:
    """What the chain reads on N chords; every array is ``(N,)``; angles in rad.

    ``sensed_horizon_nadir_rad`` = θ₀ − Gam′ (brightness-corrected) and
    ``sensed_horizon_nadir_uncorrected_rad`` = θ₀ − Gam are the nadir angles
    at which the sensor places the horizon; compare with the true hard-Earth
    horizon φ₀. NaN wherever ``status`` is not :attr:`DetectionStatus.OK`.
    """

    gam_rad: np.ndarray
    del_rad: np.ndarray
    pop_rad: np.ndarray
    gam_corrected_rad: np.ndarray
    sensed_horizon_nadir_rad: np.ndarray
    sensed_horizon_nadir_uncorrected_rad: np.ndarray
    status: np.ndarray


def _readings(scan_start, t1, t2, status, correction, params) -> ChordReadings:
    gam, dele = gam_del(t1, t2, params)
    bad = status != DetectionStatus.OK
    gam = np.where(bad, np.nan, gam)
    dele = np.where(bad, np.nan, dele)
    pop = brightness_correction(dele, correction)
    gam_corrected = gam - pop
    return ChordReadings(gam, dele, pop, gam_corrected, scan_start - gam_corrected, scan_start - gam,
                         status.astype(np.int8))


def sense_sampled_chords(radiance_of_nadir, scan_start_nadir_rad, params: ChainParameters = DEFAULT_CHAIN_PARAMETERS,
                         correction=None, steps=None, oversampling: int = 16) -> ChordReadings:
    """Stages 1–6 on any radiance profile, by sampling it: the general (slow) path.

    Args:
        radiance_of_nadir: vectorised callable, nadir angles ``(N, L)`` rad →
            radiance r.u. (the horizon profile of each chord).
        scan_start_nadir_rad: θ₀ per chord, rad, ``(N,)``.
        params: chain parameters.
        correction: the table F (see :func:`brightness_correction`).
        steps: scan steps to simulate (default ``params.max_steps``).
        oversampling: profile samples per scan step (edge positions are
            resolved to about Δ/(2·oversampling)).
    """
    theta0 = np.atleast_1d(np.asarray(scan_start_nadir_rad, float))
    n = params.max_steps if steps is None else int(steps)
    spacing = params.step_angle_rad / oversampling
    half = int(math.ceil(params.ifov_half_angle_rad / spacing)) + 1
    offsets = spacing * np.arange(-half, n * oversampling + half)
    nadir = theta0[:, None] - offsets
    energy = ifov_energy(radiance_of_nadir(nadir), spacing, params)
    energy_at_steps = energy[:, half:half + n * oversampling:oversampling]
    t1, t2, status = comparator_times(detector_lag(energy_at_steps, params), params)
    return _readings(theta0, t1, t2, status, correction, params)
