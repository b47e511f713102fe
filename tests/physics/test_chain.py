"""The signal chain of physics.md §4: each stage against a closed form, the fast chain against the oracle."""

from __future__ import annotations

import dataclasses
import json
import math
from importlib import resources

import numpy as np
import pytest
from reference_chain import reference_chord
from scipy.integrate import quad

from pmv_ros.physics import chain
from pmv_ros.physics.chain import (
    DEFAULT_CHAIN_PARAMETERS as P,
)
from pmv_ros.physics.chain import (
    DetectionStatus,
    comparator_times,
    detector_lag,
    gam_del,
    ifov_edge_response,
    ifov_energy,
    ifov_line_spread,
    pair_angles,
    scan_nadir_angles,
    sense_horizon_chords,
    sense_sampled_chords,
    sphere_chord,
)
from pmv_ros.physics.constants import ARCMIN_RAD, EARTH_MEAN_RADIUS_M
from pmv_ros.physics.geometry import sphere_tangent_height
from pmv_ros.physics.radiance import atmosphere_radiance, disc_radiance

GAMMA = P.ifov_half_angle_rad


# ---------------------------------------------------------------- instrument constants (physics.md §1)

def test_parameters_are_those_of_physics_md_section_1():
    assert math.degrees(P.ifov_full_angle_rad) == pytest.approx(2.2)
    assert math.degrees(P.scan_rate_rad_s) * 1e-3 == pytest.approx(2.46)       # °/ms
    assert P.time_step_s == pytest.approx(1e-5)                                 # 0.01 ms
    assert P.max_steps == 2000
    assert (P.threshold_1_ru, P.threshold_2_ru) == (0.33, 0.67)
    assert math.degrees(P.step_angle_rad) == pytest.approx(0.0246)


def test_defaults_hold_the_shipped_calibration():
    record = json.loads(resources.files("pmv_ros").joinpath("data", "chain_calibration.json").read_text())
    adopted = record["adopted"]
    assert P.detector_time_constant_s == adopted["detector_time_constant_s"]
    assert P.ramp.heights == tuple(adopted["ramp_heights"])
    assert P.ramp.values == tuple(adopted["ramp_values"])


@pytest.mark.parametrize("change, fragment", [
    ({"detector_time_constant_s": 0.0}, "detector_time_constant_s"),
    ({"detector_time_constant_s": math.nan}, "detector_time_constant_s"),
    ({"ifov_full_angle_rad": -1.0}, "ifov_full_angle_rad"),
    ({"max_steps": 5}, "max_steps"),
    ({"threshold_1_ru": 0.7}, "must be below threshold_2_ru"),
    ({"co2_radiance_ru": 0.4}, "co2_radiance_ru"),
    ({"window_height_m": 150e3}, "window_height_m"),
])
def test_bad_chain_parameters_raise_naming_the_value(change, fragment):
    with pytest.raises(ValueError, match=fragment):
        dataclasses.replace(P, **change)


# ---------------------------------------------------------------- geometry of a chord

def test_chord_geometry_is_the_sphere_at_zero_attitude():
    altitude = 500e3
    rho = EARTH_MEAN_RADIUS_M + altitude
    phi0, slope = sphere_chord(altitude)
    nadir = phi0 + np.radians([-0.5, 0.0, 0.7, 1.3])
    assert chain.chord_tangent_height(nadir, phi0, slope) == pytest.approx(
        sphere_tangent_height(nadir, rho, EARTH_MEAN_RADIUS_M), abs=1e-6)
    heights = np.array([0.0, 20e3, 60e3])
    assert chain.chord_tangent_height(chain.chord_nadir_of_height(heights, phi0, slope), phi0, slope) == pytest.approx(
        heights, abs=1e-6)


def test_ground_distance_of_the_weather_correlation_radius():
    # physics.md §3.1: R_x ≈ 300 km inside the horizon corresponds to dφ = 0.17° at 500 km.
    phi0, slope = sphere_chord(500e3)
    nadir = chain.chord_nadir_of_ground_distance(300e3, phi0, slope)
    assert math.degrees(phi0 - nadir) == pytest.approx(0.17, abs=0.01)  # the paper rounds to 0.01°
    assert chain.chord_ground_distance(nadir, phi0, slope) == pytest.approx(300e3, rel=1e-9)


def test_tangent_height_rate_from_two_grazing_angles_is_exact_on_a_sphere():
    phi0, slope = sphere_chord(835e3)
    layer = chain.chord_nadir_of_height(60e3, phi0, slope)
    assert chain.tangent_height_rate_from_layer(phi0, layer, 60e3) == pytest.approx(slope, rel=1e-9)


def test_tangent_height_rate_on_the_ellipsoid_places_the_layers():
    # GRS80, 500 km over 45° latitude, chord along the meridian: the equivalent sphere built from the
    # grazing angles of 0 and 60 km places the 20 and 40 km layers where the ray geometry does (to 10 m).
    from pmv_ros.physics.geometry import tangent_nadir_angles

    lat = math.radians(45.0)
    position = (EARTH_MEAN_RADIUS_M + 500e3) * np.array([math.cos(lat), 0.0, math.sin(lat)])
    up = position / np.linalg.norm(position)
    north = np.array([-math.sin(lat), 0.0, math.cos(lat)])
    axes = np.stack([north, np.cross(up, north), up], axis=1)  # sensor X north, Z up (boresight −Z = nadir)
    grazing = {h: tangent_nadir_angles(position, axes, height_m=h)[0] for h in (0.0, 20e3, 40e3, 60e3)}
    slope = chain.tangent_height_rate_from_layer(grazing[0.0], grazing[60e3], 60e3)
    for h in (20e3, 40e3):
        height = chain.chord_tangent_height(grazing[h], grazing[0.0], slope)
        assert height == pytest.approx(h, abs=10.0)


def test_chord_geometry_follows_a_shifted_horizon():
    # A tilted sensor moves the horizon along the chord; the profile moves with it.
    phi0, slope = sphere_chord(835e3)
    shift = math.radians(0.8)
    h_plain = chain.chord_tangent_height(phi0 + 0.01, phi0, slope)
    h_shifted = chain.chord_tangent_height(phi0 + shift + 0.01, phi0 + shift, slope)
    assert h_shifted == pytest.approx(h_plain, abs=1e-6)


# ---------------------------------------------------------------- stage 1: the scan

def test_scan_steps_inwards_at_w_dt():
    theta = scan_nadir_angles(1.2, steps=5)
    assert theta[0] == 1.2
    assert np.diff(theta) == pytest.approx(np.full(4, -math.radians(0.0246)), rel=1e-12)


# ---------------------------------------------------------------- stage 2: the IFOV

def test_line_spread_is_normalised_and_vanishes_outside_the_field():
    total, _ = quad(lambda a: float(ifov_line_spread(a)), -GAMMA, GAMMA)
    assert total == pytest.approx(1.0, abs=1e-9)
    assert ifov_line_spread(1.0001 * GAMMA) == 0.0


@pytest.mark.parametrize("fraction", [-1.2, -1.0, -0.6, -0.2, 0.0, 0.3, 0.9, 1.0, 1.5])
def test_edge_response_is_the_circular_segment_area(fraction):
    # Closed-form truth: the share of a disc of radius γ beyond a chord at distance |u| from the centre.
    u = fraction * GAMMA
    z = min(1.0, abs(fraction))
    segment = (math.acos(z) - z * math.sqrt(1.0 - z * z)) / math.pi
    expected = 1.0 - segment if fraction > 0 else segment
    assert ifov_edge_response(u) == pytest.approx(expected, abs=1e-12)
    integral, _ = quad(lambda a: float(ifov_line_spread(a)), -u, GAMMA) if abs(u) < GAMMA else (float(u > 0), 0)
    assert ifov_edge_response(u) == pytest.approx(integral, abs=1e-9)


def test_ifov_energy_of_a_sampled_step_edge_and_of_a_uniform_field():
    spacing = P.step_angle_rad / 16
    n = 3000
    xi = (np.arange(n) - 1500) * spacing  # inwards of the edge
    step = np.where(xi >= 0.0, 2.5, 0.0)
    energy = ifov_energy(step, spacing)
    # The sampled edge is a ramp over one sample: the closed form shifted by half a sample.
    expected = 2.5 * ifov_edge_response(xi + 0.5 * spacing)
    inside = slice(800, n - 800)  # more than γ (716 samples) from either end
    assert np.max(np.abs(energy[inside] - expected[inside])) < 2.5 * 2e-4
    assert ifov_energy(np.full(n, 1.7), spacing)[inside] == pytest.approx(1.7, abs=1e-12)


# ---------------------------------------------------------------- stage 3: the lag

def test_lag_response_of_a_step_is_one_minus_exp():
    t = np.arange(400) * P.time_step_s
    out = detector_lag(np.ones(400))
    assert out == pytest.approx(1.0 - np.exp(-t / P.detector_time_constant_s), abs=1e-12)


def test_lag_recursion_equals_the_duhamel_sum_as_written():
    rng = np.random.default_rng(7)
    energy = np.cumsum(rng.uniform(-0.05, 0.1, 120))
    t = np.arange(120) * P.time_step_s
    literal = []
    for v in range(120):
        total = 0.0
        for j in range(v + 1):
            d_u = energy[j] - (energy[j - 1] if j else 0.0)
            total += d_u * (1.0 - math.exp(-(t[v] - t[j]) / P.detector_time_constant_s))
        literal.append(total)
    assert detector_lag(energy) == pytest.approx(literal, abs=1e-12)


# ---------------------------------------------------------------- stages 4–7

def test_comparators_interpolate_linearly_between_steps():
    y = np.array([0.0, 0.1, 0.3, 0.5, 0.6, 0.9, 1.0])
    t1, t2, status = comparator_times(y)
    # 0.33 J between steps 2 (0.3) and 3 (0.5): 2.15 steps; 0.67 J between 4 (0.6) and 5 (0.9): 4.2333 steps.
    assert t1 == pytest.approx(2.15 * P.time_step_s)
    assert t2 == pytest.approx((4 + 0.07 / 0.3) * P.time_step_s)
    assert status == DetectionStatus.OK


def test_comparators_report_a_threshold_never_reached():
    t1, t2, status = comparator_times(np.array([[0.0, 0.2, 0.3, 0.31], [0.0, 0.2, 0.5, 0.6]]))
    assert np.isnan(t1[0]) and np.isnan(t2[0]) and status[0] == DetectionStatus.FIRST_THRESHOLD_NOT_REACHED
    assert not np.isnan(t1[1]) and np.isnan(t2[1]) and status[1] == DetectionStatus.SECOND_THRESHOLD_NOT_REACHED


def test_gam_del_and_pair_angle():
    gam, delta = gam_del(1e-3, 1.5e-3)
    assert gam == pytest.approx(math.radians(2.46))
    assert delta == pytest.approx(math.radians(1.23))
    assert pair_angles(0.3, 0.1) == pytest.approx(0.1)
    assert chain.brightness_correction(np.array([0.01, np.nan])).tolist()[0] == 0.0


# ---------------------------------------------------------------- the fast chain against the oracle

REFERENCE_GRID = [(h, hw, b) for h in (500e3, 835e3) for hw in (20e3, 40e3, 60e3) for b in (1.0, 2.0, 3.0, 4.0)]


def test_fast_chain_agrees_with_the_reference_transcription_over_the_grid():
    # Issue 3: within 0.05′ in Gam and Del for radiances 1–4 r.u., heights 20–60 km, altitudes 500 and 835 km.
    # The 0.05′ is the bound; the two differ only by table interpolation and quadrature (≈ 1e-4′).
    worst_gam = worst_del = 0.0
    for altitude in (500e3, 835e3):
        phi0, slope = sphere_chord(altitude)
        cases = [(hw, b) for h, hw, b in REFERENCE_GRID if h == altitude]
        fast = sense_horizon_chords(phi0, slope, np.array([b for _, b in cases]),
                                    window_height_m=np.array([hw for hw, _ in cases]))
        assert np.all(fast.status == DetectionStatus.OK)
        for k, (hw, b) in enumerate(cases):
            ref = reference_chord(phi0, slope, b, P, window_height_m=hw)
            worst_gam = max(worst_gam, abs(fast.gam_rad[k] - ref["gam_rad"]) / ARCMIN_RAD)
            worst_del = max(worst_del, abs(fast.del_rad[k] - ref["del_rad"]) / ARCMIN_RAD)
    assert worst_gam < 0.05
    assert worst_del < 0.05


MIXED_CASES = [
    # altitude, horizon shift (rad), slope factor, radius factor, B_m, gradient, jump, jump distance, h_w, CO₂ top
    (500e3, 0.0, 1.0, 1.0, 1.6, (3.5 - 1.6) / 4.891e6, 0.0, math.inf, 40e3, 60e3),       # Model B, chord 1
    (500e3, 0.0, 1.0, 1.0, 3.5, -(3.5 - 1.6) / 4.891e6, 0.0, math.inf, 40e3, 60e3),      # Model B, chord 2
    (500e3, 0.0, 1.0, 1.0, 1.0, 0.0, 0.4, 300e3, 40e3, 60e3),                            # Model C, dark
    (835e3, 0.02, 1.03, 0.998, 2.2, 2e-7, -0.3, 150e3, 55e3, 58e3),                      # tilted, oblate-ish
    (300e3, -0.015, 0.97, 1.002, 1.3, -3e-7, 0.35, 600e3, 5e3, 62e3),
    (2000e3, 0.0, 1.0, 1.0, 2.8, 4e-7, 0.2, 50e3, 80e3, 60e3),                           # h_w above the CO₂ top
]


@pytest.mark.parametrize("case", MIXED_CASES)
def test_fast_chain_agrees_with_the_reference_on_gradients_jumps_and_tilts(case):
    altitude, shift, slope_factor, radius_factor, b_m, gradient, jump, jump_d, h_w, top = case
    phi0, slope = sphere_chord(altitude)
    kwargs = dict(gradient_ru_per_m=gradient, jump_ru=jump, jump_distance_m=jump_d, window_height_m=h_w,
                  co2_top_height_m=top, earth_radius_m=EARTH_MEAN_RADIUS_M * radius_factor)
    ref = reference_chord(phi0 + shift, slope * slope_factor, b_m, P, **kwargs)
    fast = sense_horizon_chords(phi0 + shift, slope * slope_factor, b_m, **kwargs)
    assert fast.status[0] == DetectionStatus.OK
    # Same bound as the grid; the gradient's power-series fit adds < 0.005′.
    assert fast.gam_rad[0] == pytest.approx(ref["gam_rad"], abs=0.05 * ARCMIN_RAD)
    assert fast.del_rad[0] == pytest.approx(ref["del_rad"], abs=0.05 * ARCMIN_RAD)


def test_late_crossings_are_found_beyond_the_first_search_window():
    # A scan that starts 6° out crosses ≈ 250 steps later than usual: the window-by-window continuation.
    phi0, slope = sphere_chord(500e3)
    start = chain.scan_start_nadir_angle(phi0, slope) + math.radians(6.0)
    ref = reference_chord(phi0, slope, 1.0, P, scan_start_nadir_rad=start)
    fast = sense_horizon_chords(phi0, slope, 1.0, scan_start_nadir_rad=start)
    assert ref["steps"] > chain.COARSE_STRIDE * chain.COARSE_POINTS
    assert fast.gam_rad[0] == pytest.approx(ref["gam_rad"], abs=0.05 * ARCMIN_RAD)
    assert fast.del_rad[0] == pytest.approx(ref["del_rad"], abs=0.05 * ARCMIN_RAD)


def test_sensed_horizon_does_not_depend_on_where_the_scan_starts():
    # A fixed instrument scan start: the sensed horizon nadir angle θ₀ − Gam must not move with θ₀ beyond
    # the sub-step sampling phase (measured ≈ 0.004′; 0.01′ allowed).
    phi0, slope = sphere_chord(500e3)
    start = chain.scan_start_nadir_angle(phi0, slope) + np.linspace(0.0, math.radians(1.0), 37)
    readings = sense_horizon_chords(phi0, slope, 2.4, scan_start_nadir_rad=start)
    spread = np.ptp(readings.sensed_horizon_nadir_uncorrected_rad) / ARCMIN_RAD
    assert spread < 0.01


def test_staged_sampled_path_agrees_with_the_fast_chain():
    # The general path (sample the profile, stages 2–4 in turn) on Model A's profile at 500 km;
    # 32 samples per step place edges to ≈ 0.02′, hence 0.05′.
    phi0, slope = sphere_chord(500e3)
    radii = np.array([1.0, 2.5, 4.0])
    start = chain.scan_start_nadir_angle(phi0, slope)

    def profile(nadir):
        height = chain.chord_tangent_height(nadir, phi0, slope)
        distance = chain.chord_ground_distance(np.minimum(nadir, phi0), phi0, slope)
        b = radii[:, None]
        return np.where(height > 0.0, atmosphere_radiance(np.maximum(height, 0.0), b),
                        disc_radiance(distance, b))

    sampled = sense_sampled_chords(profile, np.full(3, start), steps=400, oversampling=32)
    fast = sense_horizon_chords(phi0, slope, radii, scan_start_nadir_rad=start)
    assert sampled.gam_rad == pytest.approx(fast.gam_rad, abs=0.05 * ARCMIN_RAD)
    assert sampled.del_rad == pytest.approx(fast.del_rad, abs=0.05 * ARCMIN_RAD)


def test_a_batch_equals_chord_by_chord():
    phi0, slope = sphere_chord(500e3)
    b = np.array([1.0, 1.7, 3.9, 2.2])
    gradient = np.array([0.0, 2e-7, 0.0, -1e-7])
    jump = np.array([0.0, 0.0, 0.3, 0.0])
    batch = sense_horizon_chords(phi0, slope, b, gradient_ru_per_m=gradient, jump_ru=jump, jump_distance_m=200e3)
    for k in range(4):
        one = sense_horizon_chords(phi0, slope, b[k], gradient_ru_per_m=gradient[k], jump_ru=jump[k],
                                   jump_distance_m=200e3)
        assert one.gam_rad[0] == pytest.approx(batch.gam_rad[k], abs=1e-12)
        assert one.del_rad[0] == pytest.approx(batch.del_rad[k], abs=1e-12)


# ---------------------------------------------------------------- per-chord failures: NaN + reason, no exception

def test_bad_chords_give_nan_and_a_reason_code_without_raising():
    phi0, slope = sphere_chord(500e3)
    start = chain.scan_start_nadir_angle(phi0, slope)
    readings = sense_horizon_chords(
        phi0, slope,
        np.array([2.0, np.nan, -1.0, 2.0, 2.0, 0.2, 0.5, 2.0]),
        window_height_m=np.array([40e3, 40e3, 40e3, 150e3, 40e3, 40e3, 40e3, 40e3]),
        co2_radiance_ru=np.array([0.3, 0.3, 0.3, 0.3, 0.4, 0.3, 0.3, 0.3]),
        scan_start_nadir_rad=np.array([start] * 7 + [start - math.radians(0.5)]))
    assert readings.status.tolist() == [
        DetectionStatus.OK, DetectionStatus.INVALID_INPUT, DetectionStatus.INVALID_INPUT, DetectionStatus.INVALID_INPUT,
        DetectionStatus.INVALID_INPUT, DetectionStatus.FIRST_THRESHOLD_NOT_REACHED,
        DetectionStatus.SECOND_THRESHOLD_NOT_REACHED,
        DetectionStatus.SCAN_STARTED_IN_ATMOSPHERE]
    for name in ("gam_rad", "del_rad", "gam_corrected_rad", "sensed_horizon_nadir_rad"):
        values = getattr(readings, name)
        assert np.isfinite(values[0])
        assert np.all(np.isnan(values[1:])), name


def test_horizon_beyond_the_end_of_the_scan_is_not_reached():
    short = dataclasses.replace(P, max_steps=50)
    phi0, slope = sphere_chord(500e3)
    readings = sense_horizon_chords(phi0, slope, 2.0, params=short)
    assert readings.status[0] == DetectionStatus.FIRST_THRESHOLD_NOT_REACHED


def test_empty_batch():
    readings = sense_horizon_chords(np.empty(0), 2.5e6, 2.0)
    assert readings.gam_rad.shape == (0,) and readings.status.shape == (0,)


def test_shapes_that_do_not_broadcast_raise():
    with pytest.raises(ValueError):
        sense_horizon_chords(np.ones(3), np.ones(2), 2.0)


def test_brighter_horizon_crosses_earlier():
    phi0, slope = sphere_chord(500e3)
    readings = sense_horizon_chords(phi0, slope, np.linspace(1.0, 4.0, 13))
    assert np.all(np.diff(readings.gam_rad) < 0.0)
    assert np.all(np.diff(readings.del_rad) < 0.0)  # a brighter horizon has a steeper leading edge


@pytest.mark.parametrize("size", [1, 2, 7, 97, 1009, 32_843, 65_537])
def test_the_fast_chains_convolution_and_lag_are_scipy_signals_bit_for_bit(size):
    # The fast chain builds its tables without scipy.signal (its import is ≈ 0.3 s of CPU at every start of a
    # sensor process): the same convolution and first-order lag, the same sums. Exact equality, because the golden
    # outputs are compared bit for bit.
    from scipy.signal import fftconvolve, lfilter

    from pmv_ros.physics.chain import fast

    rng = np.random.default_rng(size)
    signal, kernel = rng.uniform(0.0, 1.0, size + 40), rng.uniform(0.0, 1.0, 41)
    assert np.array_equal(fast._convolve_valid(signal, kernel), fftconvolve(signal, kernel, mode="valid"))
    x = rng.normal(size=(3, min(size, 2000)))
    assert np.array_equal(fast._first_order_lag(x, 0.93), lfilter([1.0], [1.0, -0.93], x, axis=-1))


def test_tabulated_step_response_is_stages_2_and_3_in_turn():
    # The fast chain's table for a step edge, read at the scan steps, must equal the edge response
    # (stage 2, closed form) put through the lag (stage 3), for any sub-step phase of the edge.
    tables = chain.response_tables(P)
    for phase, tolerance in ((0.0, 1e-10), (0.3125, 1e-10), (0.37, 1e-7)):
        # Phases on the table grid (multiples of 1/16 step) are exact; between grid points the linear
        # interpolation errs by < 1e-7 r.u. (≈ 1e-5′ of crossing angle).
        u = (np.arange(300) - 60 + phase) * P.step_angle_rad
        staged = detector_lag(ifov_edge_response(u))
        assert tables.response(0, u) == pytest.approx(staged, abs=tolerance)
    # Without lag (T_p → 0) the tabulated response is the edge response one step late: in the Duhamel sum
    # as written the increment dU_v enters with weight 1 − exp(0) = 0 at its own step t_v.
    instantaneous = chain.ResponseTables(dataclasses.replace(P, detector_time_constant_s=1e-9))
    u = np.array([-2.0, -0.5, 0.0, 0.5, 2.0]) * GAMMA
    assert instantaneous.response(0, u) == pytest.approx(ifov_edge_response(u - P.step_angle_rad), abs=1e-7)
