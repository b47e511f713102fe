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

Speed (benchmarks/bench_chain.py, one core): ≈ 3·10⁵ chords/s in
batches of ≥ 10⁴ chords; a call costs ≈ 0.5 ms of fixed overhead, so
batch the chords of many time samples into one call.

Agreement with the literal loop program (tests/reference_chain.py):
within 0.05′ in Gam and Del (tests/physics/test_chain.py).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..constants import EARTH_MEAN_RADIUS_M
from ..radiance import CO2_RADIANCE_RU, CO2_TOP_HEIGHT_M, MAX_LAYER_HEIGHT_M
from .chord_geometry import _central_angle_inwards, chord_nadir_of_ground_distance, chord_nadir_of_height
from .parameters import DEFAULT_CHAIN_PARAMETERS, ChainParameters, DetectionStatus
from .stages import ChordReadings, _hat_kernel, _readings, ifov_edge_response

#: Table samples per scan step (the interpolation error is then < 0.001′).
TABLE_OVERSAMPLING = 16
#: Coarse-search stride, steps, and points per coarse window (288 steps: 99.5 % of crossings
#: of a varied batch fall in the first window; the rest continue window by window).
COARSE_STRIDE = 16
COARSE_POINTS = 18
#: Table look-ups per evaluation block (keeps the working set in cache).
EVALUATION_CHUNK = 1 << 16
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
        # Flat table of value + i·(slope to the next entry): one gather per term and step.
        slopes = np.diff(self.values, axis=1, append=self.values[:, -1:])
        self.flat_complex = (self.values + 1j * slopes).ravel()

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
    target = _central_angle_inwards(fit_range[:, None] * z[None, :], kappa[:, None])
    return (target @ projector.T) / fit_range[:, None] ** powers[None, :]


@lru_cache(maxsize=1)
def _ground_distance_table():
    """The fit tabulated against log κ (the coefficients are smooth in κ; interpolation error < 1 m)."""
    log_kappa = np.linspace(*np.log(_KAPPA_RANGE), _KAPPA_SAMPLES)
    return log_kappa, _ground_distance_fit(np.exp(log_kappa))


def _ground_distance_coefficients(kappa):
    """Per chord, c_j of d(x)/R ≈ Σ c_j·x^p_j (interpolated in the table; κ clamped to its range)."""
    log_kappa, table = _ground_distance_table()
    x = np.log(np.clip(kappa, *_KAPPA_RANGE))
    return np.stack([np.interp(x, log_kappa, table[:, j]) for j in range(table.shape[1])], axis=1)


@lru_cache(maxsize=1)
def _disc_sample_inverse():
    """Inverse of V[k, j] = x_k^p_j: the powers' coefficients that pass through the disc samples."""
    x = np.asarray(DISC_SAMPLE_INWARD_RAD)
    return np.linalg.inv(x[:, None] ** np.asarray(DISC_SAMPLE_POWERS)[None, :])


def prepare(params: ChainParameters = DEFAULT_CHAIN_PARAMETERS) -> None:
    """Build now what the chain's first :func:`sense_horizon_chords` of ``params`` would build: the response
    tables, the ground-distance table, the disc-sample inverse.
    All cached, none random: what the chain then reads is unchanged."""
    response_tables(params)
    _ground_distance_table()
    _disc_sample_inverse()


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


def _as_chords(value, n, name):
    array = np.asarray(value, float)
    try:
        return np.broadcast_to(array, (n,)).astype(float, copy=True)
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
    that chord; nothing raises for bad samples.

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
        correction: the brightness-correction table F (callable Del → POP, rad) or None.
        params: chain parameters.

    Returns:
        :class:`ChordReadings` with ``(N,)`` arrays.
    """
    inputs = [horizon_nadir_rad, tangent_height_rate_m, disc_radiance_ru, gradient_ru_per_m, jump_ru,
              jump_distance_m, earth_radius_m]
    optional = [scan_start_nadir_rad, window_height_m, co2_radiance_ru, co2_top_height_m]
    n = int(np.broadcast(*[np.asarray(a, float) for a in inputs + [o for o in optional if o is not None]]).size)
    if n == 0:
        empty = np.empty(0)
        return ChordReadings(empty, empty, empty, empty, empty, empty, np.empty(0, np.int8))
    phi0 = _as_chords(horizon_nadir_rad, n, "horizon_nadir_rad")
    slope = _as_chords(tangent_height_rate_m, n, "tangent_height_rate_m")
    b_m = _as_chords(disc_radiance_ru, n, "disc_radiance_ru")
    gradient = _as_chords(gradient_ru_per_m, n, "gradient_ru_per_m")
    jump = _as_chords(jump_ru, n, "jump_ru")
    jump_d = _as_chords(jump_distance_m, n, "jump_distance_m")
    radius = _as_chords(earth_radius_m, n, "earth_radius_m")
    h_w = _as_chords(params.window_height_m if window_height_m is None else window_height_m, n, "window_height_m")
    b_a = _as_chords(params.co2_radiance_ru if co2_radiance_ru is None else co2_radiance_ru, n, "co2_radiance_ru")
    h_co2 = _as_chords(params.co2_top_height_m if co2_top_height_m is None else co2_top_height_m, n,
                       "co2_top_height_m")
    if disc_samples_ru is None:
        disc_c = None
    else:
        samples = np.asarray(disc_samples_ru, float)
        try:
            samples = np.broadcast_to(samples, (n, len(DISC_SAMPLE_INWARD_RAD)))
        except ValueError:
            raise ValueError(f"disc_samples_ru has shape {samples.shape}, which does not broadcast to "
                             f"({n}, {len(DISC_SAMPLE_INWARD_RAD)})") from None
        with np.errstate(invalid="ignore"):
            disc_c = (samples - b_m[:, None]) @ _disc_sample_inverse().T

    with np.errstate(invalid="ignore"):
        valid = (np.isfinite(phi0) & (phi0 > 0.0) & (phi0 <= 0.5 * math.pi)
                 & np.isfinite(slope) & (slope > 0.0) & np.isfinite(radius) & (radius > 0.0)
                 & np.isfinite(b_m) & (b_m > 0.0) & np.isfinite(gradient) & np.isfinite(jump)
                 & ~np.isnan(jump_d) & (jump_d >= 0.0)
                 & (h_w >= 0.0) & (h_w <= MAX_LAYER_HEIGHT_M)
                 & (b_a >= 0.0) & (b_a < params.threshold_1_ru)
                 & (h_co2 >= 0.0) & (h_co2 <= MAX_LAYER_HEIGHT_M))
        if disc_c is not None:
            valid &= np.all(np.isfinite(disc_c), axis=1)
            disc_c[~valid] = 0.0
    # Neutral stand-ins keep the arithmetic quiet on invalid chords; their results are discarded.
    phi0[~valid], slope[~valid], radius[~valid], b_m[~valid] = 1.0, 2.5e6, EARTH_MEAN_RADIUS_M, 1.0
    gradient[~valid], jump[~valid], jump_d[~valid], h_w[~valid] = 0.0, 0.0, math.inf, 40e3
    b_a[~valid], h_co2[~valid] = CO2_RADIANCE_RU, CO2_TOP_HEIGHT_M

    h_top = np.maximum(h_co2, h_w)
    phi_top = chord_nadir_of_height(h_top, phi0, slope, radius)
    if scan_start_nadir_rad is None:
        theta0 = phi_top + params.ifov_half_angle_rad
    else:
        theta0 = _as_chords(scan_start_nadir_rad, n, "scan_start_nadir_rad")
        valid &= np.isfinite(theta0)
        theta0[~valid] = phi_top[~valid] + params.ifov_half_angle_rad
    status = np.where(valid, DetectionStatus.OK, DetectionStatus.INVALID_INPUT).astype(np.int8)
    started_inside = valid & (phi_top > theta0 - params.ifov_half_angle_rad + 1e-12)
    status[started_inside] = DetectionStatus.SCAN_STARTED_IN_ATMOSPHERE

    origins, coefficients, shapes = _profile_terms(phi0, slope, radius, b_m, gradient, jump, jump_d, h_w, b_a,
                                                   phi_top, params, disc_c)
    tables = response_tables(params)
    # Geometry with no real solution (e.g. a layer above the orbit of the equivalent sphere) is bad input.
    finite = np.all(np.isfinite(origins) & np.isfinite(coefficients), axis=1)
    status[(status == DetectionStatus.OK) & ~finite] = DetectionStatus.INVALID_INPUT
    coefficients[~finite] = 0.0
    origins[~finite] = 0.0
    active = status == DetectionStatus.OK
    t1 = np.full(n, np.nan)
    t2 = np.full(n, np.nan)
    if active.any():
        # The output stays ≤ B_a < J(1) until the field reaches the window ramp: start searching there.
        phi_w = chord_nadir_of_height(h_w, phi0, slope, radius)
        first_step = np.floor((theta0 - params.ifov_half_angle_rad - phi_w) / params.step_angle_rad)
        first_step = np.clip(np.nan_to_num(first_step), 0, params.max_steps - 1).astype(np.int64)
        idx = np.flatnonzero(active)
        t1[idx], t2[idx] = _search_crossings(tables, origins[idx] - theta0[idx, None], coefficients[idx], shapes,
                                             first_step[idx], params)
    status[active & np.isnan(t1)] = DetectionStatus.FIRST_THRESHOLD_NOT_REACHED
    status[active & ~np.isnan(t1) & np.isnan(t2)] = DetectionStatus.SECOND_THRESHOLD_NOT_REACHED
    return _readings(theta0, t1, t2, status, correction, params)


def _profile_terms(phi0, slope, radius, b_m, gradient, jump, jump_d, h_w, b_a, phi_top, params, disc_c=None):
    """Decompose each chord's profile into elementary shapes: origins (N, K), coefficients (N, K), shapes (K,).

    Shapes whose coefficient is zero on every chord are dropped. The disc's
    powers x^p (gradient, sampled profile) start at the horizon φ₀, where the
    window ramp has its lowest knot: its x and x² terms share that knot's
    terms (one look-up each instead of two).
    """
    n = phi0.size
    origins, coefficients, shapes = [], [], []

    def add(shape, origin, coefficient):
        if np.any(coefficient != 0.0):
            origins.append(origin)
            coefficients.append(coefficient)
            shapes.append(shape)

    # The top of the atmosphere: space → B_a (the CO₂ layer, or the top of the window layer if higher).
    add(_STEP, phi_top, b_a.copy())

    # The window ramp B_a + (B_m − B_a)·S(h/h_w), piecewise linear in h, knots from the top down.
    knot_u = np.asarray(params.ramp.heights)[::-1]
    knot_s = np.asarray(params.ramp.values)[::-1]
    flat = h_w < 1.0  # a window layer at the surface: the ramp is a step at the horizon
    heights = knot_u[None, :] * h_w[:, None]
    knot_nadir = chord_nadir_of_height(heights, phi0[:, None], slope[:, None], radius[:, None])
    knot_value = b_a[:, None] + (b_m - b_a)[:, None] * knot_s[None, :]
    # On a segment, with ξ inwards of its upper knot: h ≈ h_k + A ξ − ½(R + h_mid) ξ²,
    # exact at both knots; the profile is P_k + b (h − h_k), b = ΔP/Δh.
    seg_length = knot_nadir[:, :-1] - knot_nadir[:, 1:]
    seg_dh = heights[:, 1:] - heights[:, :-1]
    with np.errstate(invalid="ignore", divide="ignore"):
        seg_b = np.where(seg_dh != 0.0, (knot_value[:, 1:] - knot_value[:, :-1]) / seg_dh, 0.0)
        curvature = radius[:, None] + 0.5 * (heights[:, 1:] + heights[:, :-1])
        seg_a = np.where(seg_length > 0.0, seg_dh / seg_length, 0.0) + 0.5 * curvature * seg_length
    linear = seg_b * seg_a                      # dP/dξ at the segment's upper knot
    quadratic = -0.5 * seg_b * curvature        # coefficient of ξ²
    zeros = np.zeros((n, 1))
    lin_before = np.hstack([zeros, linear + 2.0 * quadratic * seg_length])   # slope arriving at each knot
    lin_after = np.hstack([linear, zeros])                                   # slope leaving it
    quad_before = np.hstack([zeros, quadratic])
    quad_after = np.hstack([quadratic, zeros])
    jump_in_slope = np.where(flat[:, None], 0.0, lin_after - lin_before)
    jump_in_curve = np.where(flat[:, None], 0.0, quad_after - quad_before)

    # The disc: a gradient along the surface, d(x) ≈ R Σ c_j x^p_j, and a sampled profile Σ c_j x^p_j.
    disc = np.zeros((n, len(GROUND_DISTANCE_POWERS)))
    if np.any(gradient != 0.0):
        disc += _ground_distance_coefficients(slope / radius) * (gradient * radius)[:, None]
    if disc_c is not None:
        for j, power in enumerate(DISC_SAMPLE_POWERS):
            disc[:, list(GROUND_DISTANCE_POWERS).index(power)] += disc_c[:, j]
    powers = list(GROUND_DISTANCE_POWERS)
    lowest = knot_u.size - 1 if knot_u[-1] == 0.0 else None
    if lowest is not None:  # the ramp's lowest knot is the horizon φ₀: share its x and x² terms
        jump_in_slope[:, lowest] += disc[:, powers.index(1.0)]
        jump_in_curve[:, lowest] += disc[:, powers.index(2.0)]
    for k in range(knot_u.size):
        add(_LINEAR, knot_nadir[:, k], jump_in_slope[:, k])
        add(_QUADRATIC, knot_nadir[:, k], jump_in_curve[:, k])
    add(_STEP, phi0, np.where(flat, b_m - b_a, 0.0))
    for j, power in enumerate(powers):
        if lowest is not None and power in (1.0, 2.0):
            continue
        shape = {0.5: _SQRT, 1.0: _LINEAR, 1.5: _POW15, 2.0: _QUADRATIC}[power]
        add(shape, phi0, disc[:, j])
    if np.any(jump != 0.0):
        jump_nadir = chord_nadir_of_ground_distance(np.where(np.isfinite(jump_d), jump_d, 0.0), phi0, slope, radius)
        add(_STEP, jump_nadir, np.where(np.isfinite(jump_d), jump, 0.0))
    return np.stack(origins, axis=1), np.stack(coefficients, axis=1), np.asarray(shapes)


def _search_crossings(tables: ResponseTables, origin_offset, coefficients, shapes, first_step, params):
    """First interpolated crossings of J(1) and J(2), in seconds from the scan start (NaN if none).

    A coarse pass every COARSE_STRIDE steps finds, for each threshold, the
    first coarse step above it; bisection then narrows the bracket (last
    coarse step at or below, first above) to two adjacent steps, between
    which the comparator interpolates linearly.

    Args:
        origin_offset: (N, K) φ_k − θ₀ of every term, rad.
        coefficients: (N, K) term amplitudes.
        shapes: (K,) table rows.
        first_step: (N,) step at which to start the search.
    """
    m = TABLE_OVERSAMPLING
    position = origin_offset / tables.spacing_rad + tables.zero_index
    base = np.floor(position)
    frac = position - base
    # Table row offsets folded into the base index; int32 halves the index traffic.
    base = (base + (shapes * tables.length)[None, :]).astype(np.int32)
    row_start = np.broadcast_to((shapes * tables.length)[None, :], base.shape).astype(np.int32)
    # Re(w·(value + i·slope)) with w = c − i·c·frac is c·(value + frac·slope): one gather per term.
    weights = coefficients - 1j * (coefficients * frac)
    last_step = params.max_steps - 1

    def output(rows, steps):
        """Detector output at integer steps ``steps`` (len(rows), P) of the chords ``rows``."""
        result = np.empty(steps.shape)
        k = base.shape[1]
        chunk = max(1, EVALUATION_CHUNK // (k * steps.shape[1]))
        for lo in range(0, rows.size, chunk):
            r = rows[lo:lo + chunk]
            index = base[r, :, None] + (m * steps[lo:lo + chunk, None, :]).astype(np.int32)
            # Far before a term's origin its response is 0: clamp to the row's first (zero) entry.
            np.maximum(index, row_start[r, :, None], out=index)
            values = tables.flat_complex[index]
            result[lo:lo + chunk] = np.einsum("nk,nkp->np", weights[r], values).real
        return result

    thresholds = (params.threshold_1_ru, params.threshold_2_ru)
    n = first_step.size
    coarse_found = [np.full(n, -1, np.int64), np.full(n, -1, np.int64)]
    pending = np.arange(n)
    start = first_step.astype(np.int64)
    span = COARSE_STRIDE * np.arange(COARSE_POINTS)
    while pending.size:
        steps = start[pending, None] + span[None, :]
        y = output(pending, np.minimum(steps, last_step))
        y[steps > last_step] = -np.inf
        for which, threshold in enumerate(thresholds):
            todo = coarse_found[which][pending] < 0
            above = y > threshold
            hit = above.any(axis=1) & todo
            coarse_found[which][pending[hit]] = steps[hit, np.argmax(above[hit], axis=1)]
        # Continue, window by window, with chords for which a threshold is still unseen.
        start[pending] += COARSE_STRIDE * COARSE_POINTS
        unresolved = (coarse_found[0][pending] < 0) | (coarse_found[1][pending] < 0)
        pending = pending[unresolved & (start[pending] <= last_step)]

    times = []
    for which, threshold in enumerate(thresholds):
        time = np.full(n, np.nan)
        rows = np.flatnonzero(coarse_found[which] >= 0)
        if rows.size:
            hi = coarse_found[which][rows]
            lo = np.maximum(hi - COARSE_STRIDE, 0)
            ends = output(rows, np.stack([lo, hi], axis=1))
            y_lo, y_hi = ends[:, 0], ends[:, 1]
            while np.any(hi - lo > 1):
                mid = (lo + hi) // 2
                y_mid = output(rows, mid[:, None])[:, 0]
                move_hi = y_mid > threshold
                hi, y_hi = np.where(move_hi, mid, hi), np.where(move_hi, y_mid, y_hi)
                lo, y_lo = np.where(move_hi, lo, mid), np.where(move_hi, y_lo, y_mid)
            with np.errstate(invalid="ignore", divide="ignore"):
                time[rows] = (lo + (threshold - y_lo) / (y_hi - y_lo)) * params.time_step_s
        times.append(time)
    return times[0], times[1]
