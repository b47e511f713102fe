"""The fast chain, :func:`sense_horizon_chords`: superposition of precomputed responses.

Every stage up to the comparators is linear in radiance and invariant
under a shift of the scan, and the profile of physics.md §3 is a sum of a
few elementary shapes, each starting at some nadir angle φ_k:

* a step (the top of the CO₂ layer, B_a; a cloud-front jump ΔB),
* truncated powers (φ_k − θ)₊ and (φ_k − θ)₊² at each knot of the
  window ramp — the ramp is piecewise linear in tangent height and the
  tangent height is quadratic in angle across a segment, so the profile
  is a continuous piecewise quadratic in angle,
* (φ₀ − θ)₊^p for p = ½, 1, 3/2, 2: the ground distance from the horizon
  point, d(x) = R·(2 asin √(sin²(x/2) + κ sin x / 2) − x), κ = s/R,
  least-squares fitted over x ≤ min(10°, φ₀/2) and tabulated against κ
  (error < 40 m for κ < 1, i.e. orbits below ≈ 2500 km), carries a
  gradient linear over the surface (Model B).

For each shape the response of stages 2–3 *at the discrete sample times*
(including the zero-order hold the Duhamel sum implies) is a fixed
function Y(u) of the offset u = φ_k − θ_v of the sample from the shape's
origin: Y = E − G with E the IFOV-convolved shape and
G(u) = Σ_i rⁱ [E(u − iΔ) − E(u − (i+1)Δ)], r = exp(−dt/T_p), Δ = W·dt.
These Y are tabulated once per :class:`ChainParameters` on a grid 16
times finer than Δ (:class:`ResponseTables`, ≈ 15 ms). A chord's output
at step v is then Σ_k a_k·Y_k(φ_k − θ₀ + vΔ): a few table look-ups, no
convolution and no recursion. The comparators search a coarse grid
(every 16th step, 18 points) from the step where the field first reaches
the window ramp — before that the output cannot exceed B_a < J(1) — and
bisect the bracket down to the two steps the comparator interpolates
between; chords not resolved in the first window continue window by
window to the end of the scan. The output is smooth on the scale of the
field and of T_p (≈ 90 and ≈ 160 steps), so a crossing can hide between
coarse points only if the output grazes a threshold by less than
≈ 0.005 r.u. and falls back — a tangency, where the reading is
ill-conditioned anyway.

One chord is one call of the compiled kernel :func:`sense_chord`
(:mod:`pmv_ros.physics.compiled`): the sensor's kernel calls it for each chord
of each sample, :func:`sense_horizon_chords` for arrays of chords — the same
code, so a chord's reading does not depend on the batch it came in. Speed:
benchmarks/bench_chain.py.

Agreement with the literal loop program (tests/reference_chain.py):
within 0.05′ in Gam and Del (tests/physics/test_chain.py).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from ..constants import EARTH_MEAN_RADIUS_M
from ..radiance import MAX_LAYER_HEIGHT_M
from ..compiled import kernel
from .chord_geometry import central_angle_inwards, nadir_of_ground_distance, nadir_of_height
from .parameters import DEFAULT_CHAIN_PARAMETERS, ChainParameters, DetectionStatus
from .stages import ChordReadings, _hat_kernel, crossing_angle, edge_slope, ifov_edge_response

#: Table samples per scan step (the interpolation error is then < 0.001′).
TABLE_OVERSAMPLING = 16
#: Coarse-search stride, steps, and points per coarse window (288 steps: 99.5 % of crossings
#: of a varied batch fall in the first window; the rest continue window by window).
COARSE_STRIDE = 16
COARSE_POINTS = 18
#: Powers of the inward angle x that carry the ground distance d(x) (gradient over the surface).
GROUND_DISTANCE_POWERS = (0.5, 1.0, 1.5, 2.0)
#: Fit range of d(x): x ≤ 10° (and ≤ half the disc), rad.
GROUND_DISTANCE_FIT_RAD = math.radians(10.0)
#: Inward angles x from the hard-Earth horizon, rad, at which a sampled disc profile is given
#: (:func:`sense_horizon_chords` ``disc_samples_ru``): ≈ 440, 830 and 1400 km of ground inside the horizon
#: at 835 km. They span the ground the IFOV covers while the comparators fire: the far edge of the field
#: reaches x ≈ 1.4° (4 r.u.) … 2.0° (2.4 r.u.) … 4.9° (1 r.u., the darkest horizon, whose J(2) crossing
#: comes late) at t(2), at 500 and 835 km alike. Through them and B_m at x = 0, the powers
#: :data:`DISC_SAMPLE_POWERS` carry a radiance linear in ground distance to ≈ 1 km of distance.
DISC_SAMPLE_INWARD_RAD = tuple(math.radians(x) for x in (0.3, 1.2, 4.5))
#: Powers of x in the interpolant of the disc samples: x and x² share the window ramp's lowest knot, so a
#: sampled disc costs the chain one term (x^½) more than a uniform one.
DISC_SAMPLE_POWERS = (0.5, 1.0, 2.0)

# The elementary shapes, their table rows.
_STEP, _LINEAR, _QUADRATIC, _SQRT, _POW15 = range(5)
_SHAPE_POWER = {_LINEAR: 1.0, _QUADRATIC: 2.0, _SQRT: 0.5, _POW15: 1.5}


class ResponseTables:
    """Responses Y(u) of stages 2–3, sampled at scan steps, to the elementary profile shapes.

    Row ``k`` of :attr:`values` is Y_k on the grid u_n = (n − n0)·δ,
    δ = Δ/TABLE_OVERSAMPLING, for the shapes step, (x)₊, (x)₊², (x)₊^½,
    (x)₊^{3/2} (x in rad inwards of the shape's origin). See the module
    docstring for the construction.
    """

    def __init__(self, params: ChainParameters):
        self.params = params
        m = TABLE_OVERSAMPLING
        self.spacing_rad = params.step_angle_rad / m
        gamma = params.ifov_half_angle_rad
        # Leading zeros: one step and a margin before the field touches the origin.
        blocks_before = int(math.ceil((gamma + params.step_angle_rad) / params.step_angle_rad)) + 1
        self.zero_index = blocks_before * m
        length = (blocks_before + params.max_steps + 2) * m
        u = (np.arange(length) - self.zero_index) * self.spacing_rad
        energy = np.empty((5, length))
        energy[_STEP] = ifov_edge_response(u, params)
        kernel, half = _hat_kernel(self.spacing_rad, gamma)
        xi = (np.arange(length + 2 * half) - self.zero_index - half) * self.spacing_rad
        xi_pos = np.maximum(xi, 0.0)
        for row, power in _SHAPE_POWER.items():
            energy[row] = _convolve_valid(xi_pos**power, kernel[::-1])
        energy[:, u < -gamma - self.spacing_rad] = 0.0  # FFT round-off where the field sees nothing
        # Detector lag at the sample times, for every sub-step phase at once:
        # G[n] = r·G[n − m] + E[n] − E[n − m]  (rows of the reshaped array are whole steps).
        blocks = energy.reshape(5, -1, m)
        increments = np.diff(blocks, axis=1, prepend=0.0)
        lagged = _first_order_lag(np.moveaxis(increments, 1, -1), params.lag_decay_per_step)
        self.values = (energy - np.moveaxis(lagged, -1, 1).reshape(5, length))
        self.length = length
        #: Slope from each entry to the next: the kernel interpolates value + fraction·slope.
        self.slopes = np.diff(self.values, axis=1, append=self.values[:, -1:])

    def response(self, shape: int, offset_rad):
        """Y of one shape at offsets u (rad, field centre inwards of the origin), linear interpolation."""
        f = np.asarray(offset_rad, float) / self.spacing_rad + self.zero_index
        i = np.clip(np.floor(f).astype(np.int64), 0, self.length - 2)
        frac = np.clip(f - i, 0.0, 1.0)
        row = self.values[shape]
        return row[i] + frac * (row[i + 1] - row[i])


# scipy.signal would do the two operations below, but its import costs ≈ 0.3 s of CPU at every start of a process
# that runs the chain (a sensor node, `pmv simulate`, a campaign worker). These are fftconvolve's and lfilter's
# arithmetic, operation for operation, on the same FFT (scipy.fft): the tables come out bit for bit as with
# scipy.signal (tests/physics/test_chain.py). numpy's FFT gave the same bits here too, but in 1 of ≈ 40 Dask
# worker processes of the campaign tests a table came out different in its last bits; scipy.fft is the FFT these
# tables have always been built with.

def _convolve_valid(signal, kernel):
    """``fftconvolve(signal, kernel, mode="valid")`` of two 1-D arrays: real FFTs of the next fast length, their
    product transformed back, the part where the kernel lies wholly within the signal."""
    from scipy import fft

    full_size = signal.size + kernel.size - 1
    size = fft.next_fast_len(full_size, True)
    full = fft.irfft(fft.rfft(signal, size) * fft.rfft(kernel, size), size)[:full_size]
    return full[kernel.size - 1:signal.size]


def _first_order_lag(x, decay):
    """y_k = x_k + decay·y_(k−1) along the last axis, from rest: ``lfilter([1], [1, −decay], x)``."""
    y = np.empty_like(x)
    y[..., 0] = x[..., 0]
    for k in range(1, x.shape[-1]):
        y[..., k] = x[..., k] + decay * y[..., k - 1]
    return y


@lru_cache(maxsize=8)
def response_tables(params: ChainParameters = DEFAULT_CHAIN_PARAMETERS) -> ResponseTables:
    """The (cached) response tables of a parameter set; building one takes ≈ 20 ms."""
    return ResponseTables(params)


#: Range and resolution of the tabulated ground-distance fit, κ = s/R (LEO ≈ 0.2 … GEO ≈ 7).
_KAPPA_RANGE = (0.02, 50.0)
_KAPPA_SAMPLES = 4001


def _ground_distance_fit(kappa):
    """c_j with d(x)/R ≈ Σ c_j·x^p_j over 0 ≤ x ≤ min(10°, φ₀/2), φ₀ = atan(1/κ), per κ (x in rad).

    Least squares on a grid of x dense near the horizon, where d(x) ∝ √x.
    """
    kappa = np.asarray(kappa, float)
    fit_range = np.minimum(GROUND_DISTANCE_FIT_RAD, 0.5 * np.arctan2(1.0, kappa))
    z = np.linspace(0.0, 1.0, 41) ** 2
    powers = np.asarray(GROUND_DISTANCE_POWERS)
    projector = np.linalg.pinv(z[:, None] ** powers[None, :])
    target = central_angle_inwards(fit_range[:, None] * z[None, :], kappa[:, None])
    return (target @ projector.T) / fit_range[:, None] ** powers[None, :]


@lru_cache(maxsize=1)
def _ground_distance_table():
    """The fit tabulated against log κ (the coefficients are smooth in κ; interpolation error < 1 m)."""
    log_kappa = np.linspace(*np.log(_KAPPA_RANGE), _KAPPA_SAMPLES)
    return log_kappa, _ground_distance_fit(np.exp(log_kappa))


@lru_cache(maxsize=1)
def _disc_sample_inverse():
    """Inverse of V[k, j] = x_k^p_j: the powers' coefficients that pass through the disc samples."""
    x = np.asarray(DISC_SAMPLE_INWARD_RAD)
    return np.linalg.inv(x[:, None] ** np.asarray(DISC_SAMPLE_POWERS)[None, :])


def prepare(params: ChainParameters = DEFAULT_CHAIN_PARAMETERS) -> None:
    """Build now what the chain's first :func:`sense_horizon_chords` of ``params`` would build: the response
    tables, the ground-distance table, the disc-sample inverse, and the compiled kernel (loaded from numba's
    cache, or compiled). All cached, none random: what the chain then reads is unchanged."""
    sense_horizon_chords(1.0, 2.5e6, 2.4, params=params)


def disc_sample_profile(inward_rad, horizon_radiance_ru, disc_samples_ru):
    """The disc radiance the chain flies for sampled points, r.u., at inward angles x (rad) from the horizon.

    B(x) = B_m + Σ_j c_j·x^p_j (p = ½, 1, 2), the c_j chosen so that B passes
    through B_m at x = 0 and through each sample at :data:`DISC_SAMPLE_INWARD_RAD`:
    an interpolation in √x — close to one in ground distance, d ∝ √x near the
    horizon — never a gradient extrapolated across the disc.

    Args:
        inward_rad: (P,) inward angles, rad.
        horizon_radiance_ru: (N,) B_m, r.u.
        disc_samples_ru: (N, 3) radiance at the sample angles, r.u.
    """
    b_m = np.asarray(horizon_radiance_ru, float)
    c = (np.asarray(disc_samples_ru, float) - b_m[..., None]) @ _disc_sample_inverse().T
    x = np.asarray(inward_rad, float)
    return b_m[..., None] + np.sum(c[..., None, :] * x[:, None] ** np.asarray(DISC_SAMPLE_POWERS), axis=-1)


#: Layout of the head of :attr:`ChainArrays.vector`: the chain's parameters as the kernel reads them, then the
#: lengths of the arrays that follow.
_GAMMA, _STEP_ANGLE, _TIME_STEP, _MAX_STEPS, _THRESHOLD_1, _THRESHOLD_2, _SCAN_RATE, _SPACING, _ZERO_INDEX, \
    _LENGTH, _KNOTS, _KAPPAS, _CORRECTIONS = range(13)
_HEAD = 13


class ChainArrays(NamedTuple):
    """What the compiled chain reads besides a chord's inputs, as two arrays (:func:`chain_kit`; a kernel's
    arguments are checked at each call, each array's quickly, a tuple's slowly): the tables of one parameter
    set and one correction table."""

    vector: np.ndarray  #: the parameters, then the ramp's knots, the ground-distance fit, the correction table
    tables: np.ndarray  #: (2, 5, L): the responses Y of the elementary shapes and the slope to the next entry

    @property
    def knots(self) -> int:
        """Knots of the window ramp (a chord has at most 2·knots + 5 profile terms)."""
        return int(self.vector[_KNOTS])


class ChainKit(NamedTuple):
    """:class:`ChainArrays` taken apart inside a kernel (:func:`unpack`)."""

    values: np.ndarray  #: (5, L) responses Y of the elementary shapes (:class:`ResponseTables`)
    slopes: np.ndarray  #: (5, L) slope from each entry to the next
    ramp_heights: np.ndarray  #: (K,) knots of the window ramp, u = h/h_w, from the top (1) down (0)
    ramp_values: np.ndarray  #: (K,) S at those knots
    log_kappa: np.ndarray  #: (S,) abscissae of the tabulated ground-distance fit, log κ
    ground_distance: np.ndarray  #: (4·S,) its coefficients c_j (powers :data:`GROUND_DISTANCE_POWERS`), by power
    disc_inverse: np.ndarray  #: (9,) the disc samples' interpolation (:data:`DISC_SAMPLE_POWERS`), row by row
    correction_del: np.ndarray  #: (M,) the correction table's Del, rad (M = 0: no correction)
    correction_pop: np.ndarray  #: (M,) its POP, rad
    scalars: np.ndarray  #: the parameters (the head of the vector)


@kernel
def unpack(vector, tables):
    """The :class:`ChainKit` of a :class:`ChainArrays` (views, no copies)."""
    knots, kappas, corrections = int(vector[_KNOTS]), int(vector[_KAPPAS]), int(vector[_CORRECTIONS])
    o = _HEAD
    ramp_heights, ramp_values = vector[o:o + knots], vector[o + knots:o + 2 * knots]
    o += 2 * knots
    log_kappa, ground_distance = vector[o:o + kappas], vector[o + kappas:o + 5 * kappas]
    o += 5 * kappas
    disc_inverse = vector[o:o + 9]
    o += 9
    return ChainKit(tables[0], tables[1], ramp_heights, ramp_values, log_kappa, ground_distance, disc_inverse,
                    vector[o:o + corrections], vector[o + corrections:o + 2 * corrections], vector[:_HEAD])


@lru_cache(maxsize=32)
def _kit(params: ChainParameters, correction_del: tuple, correction_pop: tuple) -> ChainArrays:
    tables = response_tables(params)
    log_kappa, ground_distance = _ground_distance_table()
    head = [params.ifov_half_angle_rad, params.step_angle_rad, params.time_step_s, params.max_steps,
            params.threshold_1_ru, params.threshold_2_ru, params.scan_rate_rad_s, tables.spacing_rad,
            tables.zero_index, tables.length, len(params.ramp.heights), log_kappa.size, len(correction_del)]
    vector = np.concatenate([head, params.ramp.heights[::-1], params.ramp.values[::-1], log_kappa,
                             ground_distance.T.ravel(), _disc_sample_inverse().ravel(), correction_del,
                             correction_pop]).astype(float)
    return ChainArrays(vector, np.ascontiguousarray(np.stack([tables.values, tables.slopes])))


def chain_kit(params: ChainParameters = DEFAULT_CHAIN_PARAMETERS, correction=None) -> ChainArrays:
    """The compiled chain's tables for ``params`` and a correction table (None: no correction; a
    :class:`~pmv_ros.physics.instrument.correction.CorrectionTable` or anything with ``del_rad`` and
    ``pop_rad`` arrays — the curve is applied by linear interpolation, clamped at its ends)."""
    if correction is None:
        return _kit(params, (), ())
    try:
        del_rad, pop_rad = correction.del_rad, correction.pop_rad
    except AttributeError:
        raise ValueError(f"correction {correction!r} is not a table with del_rad and pop_rad") from None
    return _kit(params, tuple(np.asarray(del_rad, float).tolist()), tuple(np.asarray(pop_rad, float).tolist()))


@kernel
def _profile_terms(phi0, slope, radius, b_m, gradient, jump, jump_d, h_w, b_a, phi_top, disc_c, sampled, kit,
                   origins, coefficients, shapes):
    """Decompose a chord's profile into elementary shapes: fills ``origins``, ``coefficients``, ``shapes``
    (the terms whose coefficient is not zero, in a fixed order) and returns their number.

    The disc's powers x^p (gradient, sampled profile) start at the horizon φ₀, where the window ramp has
    its lowest knot: its x and x² terms share that knot's terms (one look-up each instead of two).
    """
    count = 0
    # The top of the atmosphere: space → B_a (the CO₂ layer, or the top of the window layer if higher).
    if b_a != 0.0:
        origins[count], coefficients[count], shapes[count] = phi_top, b_a, _STEP
        count += 1
    # The window ramp B_a + (B_m − B_a)·S(h/h_w), piecewise linear in h, knots from the top down. On a
    # segment, with ξ inwards of its upper knot: h ≈ h_k + A ξ − ½(R + h_mid) ξ², exact at both knots; the
    # profile is P_k + b (h − h_k), b = ΔP/Δh.
    knots = kit.ramp_heights.size
    flat = h_w < 1.0  # a window layer at the surface: the ramp is a step at the horizon
    # The disc: a gradient along the surface, d(x) ≈ R Σ c_j x^p_j, and a sampled profile Σ c_j x^p_j.
    x_half = x_one = x_three_halves = x_two = 0.0  # the disc's coefficients of the powers x^p
    if gradient != 0.0:
        log_k = math.log(min(max(slope / radius, _KAPPA_RANGE[0]), _KAPPA_RANGE[1]))
        size, scale = kit.log_kappa.size, gradient * radius
        x_half += np.interp(log_k, kit.log_kappa, kit.ground_distance[:size]) * scale
        x_one += np.interp(log_k, kit.log_kappa, kit.ground_distance[size:2 * size]) * scale
        x_three_halves += np.interp(log_k, kit.log_kappa, kit.ground_distance[2 * size:3 * size]) * scale
        x_two += np.interp(log_k, kit.log_kappa, kit.ground_distance[3 * size:]) * scale
    if sampled:
        x_half += disc_c[0]
        x_one += disc_c[1]
        x_two += disc_c[2]
    linear_before = quadratic_before = 0.0  # the slope and curvature arriving at the knot
    for k in range(knots):
        height = kit.ramp_heights[k] * h_w
        nadir = nadir_of_height(height, phi0, slope, radius)
        value = b_a + (b_m - b_a) * kit.ramp_values[k]
        if k + 1 < knots:
            next_height = kit.ramp_heights[k + 1] * h_w
            next_nadir = nadir_of_height(next_height, phi0, slope, radius)
            next_value = b_a + (b_m - b_a) * kit.ramp_values[k + 1]
            seg_length = nadir - next_nadir
            seg_dh = next_height - height
            seg_b = (next_value - value) / seg_dh if seg_dh != 0.0 else 0.0
            curvature = radius + 0.5 * (next_height + height)
            seg_a = (seg_dh / seg_length if seg_length > 0.0 else 0.0) + 0.5 * curvature * seg_length
            linear_after = seg_b * seg_a  # dP/dξ at the segment's upper knot
            quadratic_after = -0.5 * seg_b * curvature  # coefficient of ξ²
        else:
            seg_length = linear_after = quadratic_after = 0.0
        slope_jump = 0.0 if flat else linear_after - linear_before
        curve_jump = 0.0 if flat else quadratic_after - quadratic_before
        if k == knots - 1:  # the lowest knot is the horizon φ₀: it carries the disc's x and x² terms
            slope_jump += x_one
            curve_jump += x_two
        if slope_jump != 0.0:
            origins[count], coefficients[count], shapes[count] = nadir, slope_jump, _LINEAR
            count += 1
        if curve_jump != 0.0:
            origins[count], coefficients[count], shapes[count] = nadir, curve_jump, _QUADRATIC
            count += 1
        linear_before = linear_after + 2.0 * quadratic_after * seg_length
        quadratic_before = quadratic_after
    if flat and b_m - b_a != 0.0:
        origins[count], coefficients[count], shapes[count] = phi0, b_m - b_a, _STEP
        count += 1
    if x_half != 0.0:
        origins[count], coefficients[count], shapes[count] = phi0, x_half, _SQRT
        count += 1
    if x_three_halves != 0.0:
        origins[count], coefficients[count], shapes[count] = phi0, x_three_halves, _POW15
        count += 1
    if jump != 0.0 and math.isfinite(jump_d):
        origins[count] = nadir_of_ground_distance(jump_d, phi0, slope, radius)
        coefficients[count], shapes[count] = jump, _STEP
        count += 1
    return count


@kernel
def _detector_output(step, count, base, fraction, coefficients, shapes, kit):
    """The detector output at integer scan step ``step``, r.u.: Σ_k c_k·Y_k at the step (table look-ups)."""
    m = TABLE_OVERSAMPLING
    last = kit.values.shape[1] - 1
    total = 0.0
    for k in range(count):
        index = base[k] + m * step
        if index < 0:  # far before a term's origin its response is 0 (the row's first entries)
            index = 0
        elif index > last:
            index = last
        c = coefficients[k]
        total += c * kit.values[shapes[k], index] + (c * fraction[k]) * kit.slopes[shapes[k], index]
    return total


@kernel
def _crossing_times(count, base, fraction, coefficients, shapes, first_step, kit):
    """First interpolated crossings of J(1) and J(2), s from the scan start (NaN if none).

    A coarse pass every COARSE_STRIDE steps finds, for each threshold, the first coarse step above it
    (window by window from ``first_step``); bisection then narrows the bracket (last coarse step at or
    below, first above) to two adjacent steps, between which the comparator interpolates linearly.
    """
    last_step = int(kit.scalars[_MAX_STEPS]) - 1
    threshold_1, threshold_2 = kit.scalars[_THRESHOLD_1], kit.scalars[_THRESHOLD_2]
    found_1 = found_2 = -1
    start = first_step
    while (found_1 < 0 or found_2 < 0) and start <= last_step:
        for point in range(COARSE_POINTS):
            step = start + COARSE_STRIDE * point
            if step > last_step:
                break
            y = _detector_output(step, count, base, fraction, coefficients, shapes, kit)
            if found_1 < 0 and y > threshold_1:
                found_1 = step
            if found_2 < 0 and y > threshold_2:
                found_2 = step
            if found_1 >= 0 and found_2 >= 0:  # the rest of the window cannot change them
                break
        start += COARSE_STRIDE * COARSE_POINTS
    return (_crossing_time(found_1, threshold_1, count, base, fraction, coefficients, shapes, kit),
            _crossing_time(found_2, threshold_2, count, base, fraction, coefficients, shapes, kit))


@kernel
def _crossing_time(found, threshold, count, base, fraction, coefficients, shapes, kit):
    """The comparator's time, s from the scan start, between the last step at or below ``threshold`` and the first
    above it, bisected from the coarse step ``found`` (−1: never above, NaN)."""
    if found < 0:
        return math.nan
    hi = found
    lo = max(hi - COARSE_STRIDE, 0)
    y_lo = _detector_output(lo, count, base, fraction, coefficients, shapes, kit)
    y_hi = _detector_output(hi, count, base, fraction, coefficients, shapes, kit)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        y_mid = _detector_output(mid, count, base, fraction, coefficients, shapes, kit)
        if y_mid > threshold:
            hi, y_hi = mid, y_mid
        else:
            lo, y_lo = mid, y_mid
    return (lo + (threshold - y_lo) / (y_hi - y_lo)) * kit.scalars[_TIME_STEP]


@kernel
def sense_chord(phi0, slope, b_m, gradient, jump, jump_d, radius, h_w, b_a, h_co2, scan_start, disc_samples,
                sampled, kit, origins, coefficients, shapes, base, fraction):
    """One chord through the chain: (Gam, Del, POP, Gam′, θ₀ − Gam′, θ₀ − Gam, status), rad and a
    :class:`DetectionStatus` code — the readings of :func:`sense_horizon_chords` (see there for the inputs;
    ``scan_start`` NaN: the chord's own default, ``disc_samples`` the three samples when ``sampled``).

    ``origins`` … ``fraction``: scratch arrays of at least the chord's number of terms.
    """
    nan = math.nan
    gamma = kit.scalars[_GAMMA]
    valid = (phi0 > 0.0 and phi0 <= 0.5 * math.pi and slope > 0.0 and slope < math.inf and radius > 0.0
             and radius < math.inf and b_m > 0.0 and b_m < math.inf and math.isfinite(gradient)
             and math.isfinite(jump) and jump_d >= 0.0 and h_w >= 0.0 and h_w <= MAX_LAYER_HEIGHT_M
             and b_a >= 0.0 and b_a < kit.scalars[_THRESHOLD_1] and h_co2 >= 0.0 and h_co2 <= MAX_LAYER_HEIGHT_M)
    c0 = c1 = c2 = 0.0
    if valid and sampled:
        inverse = kit.disc_inverse
        d0, d1, d2 = disc_samples[0] - b_m, disc_samples[1] - b_m, disc_samples[2] - b_m
        c0 = d0 * inverse[0] + d1 * inverse[1] + d2 * inverse[2]
        c1 = d0 * inverse[3] + d1 * inverse[4] + d2 * inverse[5]
        c2 = d0 * inverse[6] + d1 * inverse[7] + d2 * inverse[8]
        valid = math.isfinite(c0) and math.isfinite(c1) and math.isfinite(c2)
    if not valid:
        return nan, nan, nan, nan, nan, nan, DetectionStatus.INVALID_INPUT
    phi_top = nadir_of_height(max(h_co2, h_w), phi0, slope, radius)
    theta0 = phi_top + gamma if math.isnan(scan_start) else scan_start
    if not math.isfinite(theta0):
        return nan, nan, nan, nan, nan, nan, DetectionStatus.INVALID_INPUT
    if phi_top > theta0 - gamma + 1e-12:
        return nan, nan, nan, nan, nan, nan, DetectionStatus.SCAN_STARTED_IN_ATMOSPHERE
    count = _profile_terms(phi0, slope, radius, b_m, gradient, jump, jump_d, h_w, b_a, phi_top, (c0, c1, c2), sampled,
                           kit, origins, coefficients, shapes)
    spacing, zero_index = kit.scalars[_SPACING], kit.scalars[_ZERO_INDEX]
    for k in range(count):
        # Geometry with no real solution (e.g. a layer above the orbit of the equivalent sphere) is bad input.
        if not (math.isfinite(origins[k]) and math.isfinite(coefficients[k])):
            return nan, nan, nan, nan, nan, nan, DetectionStatus.INVALID_INPUT
        position = (origins[k] - theta0) / spacing + zero_index
        base[k] = math.floor(position)
        fraction[k] = position - base[k]
    # The output stays ≤ B_a < J(1) until the field reaches the window ramp: start searching there.
    first = math.floor((theta0 - gamma - nadir_of_height(h_w, phi0, slope, radius)) / kit.scalars[_STEP_ANGLE])
    last_step = kit.scalars[_MAX_STEPS] - 1.0
    first_step = 0 if math.isnan(first) else int(min(max(first, 0.0), last_step))
    t1, t2 = _crossing_times(count, base, fraction, coefficients, shapes, first_step, kit)
    if math.isnan(t1):
        return nan, nan, nan, nan, nan, nan, DetectionStatus.FIRST_THRESHOLD_NOT_REACHED
    if math.isnan(t2):
        return nan, nan, nan, nan, nan, nan, DetectionStatus.SECOND_THRESHOLD_NOT_REACHED
    # Stages 5–6: Gam = t(1)·W, Del = (t(2) − t(1))·W, POP = F(Del) (linear, clamped at the table's ends).
    gam = crossing_angle(t1, kit.scalars[_SCAN_RATE])
    dele = edge_slope(t1, t2, kit.scalars[_SCAN_RATE])
    pop = np.interp(dele, kit.correction_del, kit.correction_pop) if kit.correction_del.size else 0.0
    gam_corrected = gam - pop
    return gam, dele, pop, gam_corrected, theta0 - gam_corrected, theta0 - gam, DetectionStatus.OK


@kernel
def _sense_chords(phi0, slope, b_m, gradient, jump, jump_d, radius, h_w, b_a, h_co2, scan_start, disc_samples,
                  sampled, kit_vector, kit_tables, out, status):
    """:func:`sense_chord` for every chord of the flat inputs; readings into ``out`` (6, N), codes into ``status``."""
    kit = unpack(kit_vector, kit_tables)
    terms = 2 * kit.ramp_heights.size + 5  # the most a chord has: top, two a knot, flat step, two powers, jump
    origins, coefficients, fraction = np.empty(terms), np.empty(terms), np.empty(terms)
    shapes, base = np.empty(terms, np.int64), np.empty(terms, np.int64)
    for n in range(phi0.size):
        out[0, n], out[1, n], out[2, n], out[3, n], out[4, n], out[5, n], status[n] = sense_chord(
            phi0[n], slope[n], b_m[n], gradient[n], jump[n], jump_d[n], radius[n], h_w[n], b_a[n], h_co2[n],
            scan_start[n], disc_samples[n], sampled, kit, origins, coefficients, shapes, base, fraction)


def _as_chords(value, n, name):
    array = np.asarray(value, float)
    try:
        return np.ascontiguousarray(np.broadcast_to(array, (n,)))
    except ValueError:
        raise ValueError(f"{name} has shape {array.shape}, which does not broadcast to the {n} chords") from None


def sense_horizon_chords(horizon_nadir_rad, tangent_height_rate_m, disc_radiance_ru, *,
                         scan_start_nadir_rad=None, gradient_ru_per_m=0.0, jump_ru=0.0, jump_distance_m=math.inf,
                         window_height_m=None, co2_radiance_ru=None, co2_top_height_m=None,
                         disc_samples_ru=None, earth_radius_m=EARTH_MEAN_RADIUS_M, correction=None,
                         params: ChainParameters = DEFAULT_CHAIN_PARAMETERS) -> ChordReadings:
    """Gam, Del, Gam′ and the sensed horizon of N chords at once: the fast signal chain.

    Every argument is a scalar or an ``(N,)`` array (broadcast together).
    Bad values of a chord give NaN and :attr:`DetectionStatus.INVALID_INPUT` for
    that chord; nothing raises for bad samples. Each chord is one :func:`sense_chord`.

    Args:
        horizon_nadir_rad: φ₀, the chord's hard-Earth horizon nadir angle, rad
            (e.g. from :func:`pmv_ros.physics.geometry.tangent_nadir_angles`), in (0, π/2].
        tangent_height_rate_m: s = dh/dφ near the horizon, m/rad, > 0
            ((R + H)·cos φ₀ on a sphere, ≈ the slant range; on the ellipsoid
            use :func:`tangent_height_rate_from_layer` with the grazing angles
            of 0 and 60 km, which places every layer to ≈ 2 m).
        disc_radiance_ru: B_m, the Earth's radiance at the horizon point, r.u., > 0.
        scan_start_nadir_rad: θ₀, rad; default: just outside this chord's
            atmosphere, φ(max(h_CO₂, h_w)) + γ, as in the published program.
            A fixed instrument angle is fine as long as the field sees nothing at the start.
        gradient_ru_per_m: change of disc radiance per metre of ground distance
            inwards from the horizon point, r.u./m (Model B).
        jump_ru: radiance jump on the disc, r.u. (Model C), at
        jump_distance_m: ground distance of the jump inwards from the horizon point, m (≥ 0).
        window_height_m: h_w, m, in [0, 100 km] (default ``params.window_height_m``).
        co2_radiance_ru: B_a, r.u., in [0, J(1)) (default ``params.co2_radiance_ru``).
        co2_top_height_m: top of the CO₂ layer, m, in [0, 100 km] (default ``params.co2_top_height_m``).
        disc_samples_ru: ``(N, 3)`` radiance of the disc at the inward angles
            :data:`DISC_SAMPLE_INWARD_RAD` from the horizon, r.u., interpolated
            with B_m at the horizon (:func:`disc_sample_profile`); it adds to any
            gradient and jump. None: no sampled profile.
        earth_radius_m: local Earth radius R, m (the chord's curvature; mean radius by default).
        correction: the brightness-correction table F (:func:`chain_kit`) or None.
        params: chain parameters.

    Returns:
        :class:`ChordReadings` with ``(N,)`` arrays.
    """
    inputs = [horizon_nadir_rad, tangent_height_rate_m, disc_radiance_ru, gradient_ru_per_m, jump_ru,
              jump_distance_m, earth_radius_m]
    optional = [scan_start_nadir_rad, window_height_m, co2_radiance_ru, co2_top_height_m]
    n = int(np.broadcast(*[np.asarray(a, float) for a in inputs + [o for o in optional if o is not None]]).size)
    kit = chain_kit(params, correction)
    if n == 0:
        empty = np.empty(0)
        return ChordReadings(empty, empty, empty, empty, empty, empty, np.empty(0, np.int8))
    columns = [_as_chords(value, n, name) for value, name in (
        (horizon_nadir_rad, "horizon_nadir_rad"), (tangent_height_rate_m, "tangent_height_rate_m"),
        (disc_radiance_ru, "disc_radiance_ru"), (gradient_ru_per_m, "gradient_ru_per_m"), (jump_ru, "jump_ru"),
        (jump_distance_m, "jump_distance_m"), (earth_radius_m, "earth_radius_m"),
        (params.window_height_m if window_height_m is None else window_height_m, "window_height_m"),
        (params.co2_radiance_ru if co2_radiance_ru is None else co2_radiance_ru, "co2_radiance_ru"),
        (params.co2_top_height_m if co2_top_height_m is None else co2_top_height_m, "co2_top_height_m"),
        (math.nan if scan_start_nadir_rad is None else scan_start_nadir_rad, "scan_start_nadir_rad"))]
    if scan_start_nadir_rad is not None:  # a given start that is NaN is bad input, not the default
        columns[-1] = np.where(np.isnan(columns[-1]), math.inf, columns[-1])
    if disc_samples_ru is None:
        samples = np.zeros((n, 3))
    else:
        samples = np.asarray(disc_samples_ru, float)
        try:
            samples = np.ascontiguousarray(np.broadcast_to(samples, (n, len(DISC_SAMPLE_INWARD_RAD))))
        except ValueError:
            raise ValueError(f"disc_samples_ru has shape {samples.shape}, which does not broadcast to "
                             f"({n}, {len(DISC_SAMPLE_INWARD_RAD)})") from None
    out = np.empty((6, n))
    status = np.empty(n, np.int8)
    phi0, slope, b_m, gradient, jump, jump_d, radius, h_w, b_a, h_co2, start = columns
    _sense_chords(phi0, slope, b_m, gradient, jump, jump_d, radius, h_w, b_a, h_co2, start, samples,
                  disc_samples_ru is not None, *kit, out, status)
    return ChordReadings(*out, status)
