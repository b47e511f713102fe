"""The star-tracker model of physics.md §6 against the closed forms and the numbers star_tracker.md derives."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.attitude import quaternion_conjugate, quaternion_product, rotation_vector_from_quaternion
from pmv_ros.physics.constants import ARCSEC_RAD
from pmv_ros.physics.orbit.ephemeris import Epoch
from pmv_ros.physics.orbit.two_body import CircularOrbit
from pmv_ros.physics.star_tracker import (REASON_ORDER, Outcome, RadiationGrid, Sky, StarTracker, TrackerParameters,
                                          optimal_exposure_s, smear_loss_mag, trail_rate)
from pmv_ros.physics.star_tracker.draws import Draws
from pmv_ros.physics.star_tracker.model import (CCD_AREA_CM2, hit_footprint_moments, recognition_failure,
                                                rotation_matrices)
from pmv_ros.physics.star_tracker import sky as sky_module
from pmv_ros.physics.star_tracker.sky import precession_matrix

EPOCH = Epoch.from_utc("2013-09-10T00:00:00Z")
KONDOR = CircularOrbit(500e3, math.radians(74.5))


@pytest.fixture(scope="module")
def sky():
    return Sky(float(EPOCH.julian_date_tt(0.0)))


@pytest.fixture(scope="module")
def radiation():
    return RadiationGrid()


def test_the_reason_codes_are_the_specs():
    """physics.md §6: every frame without attitude says why, with these names."""
    assert {o.reason for o in REASON_ORDER} - {"invalid_truth"} == {
        "no_stars", "recognition_failure", "buffer_overflow", "exclusion", "rate_too_high", "outage"}
    assert Outcome.OK.value == 0 and Outcome.NO_STARS.reason == "no_stars"


def test_timing_and_smear_are_the_texts_arithmetic():
    """star_tracker.md §6.1 [D]: t_opt = 171.9″/ω: 0.75 s at 500 km (228.6″/s), 0.81 s at 835 km (212.9″/s);
    ΔM_rate = 2.5·lg(ω·t/171.9″): 0 at the optimum, 1.06 mag at 228.6″/s with 2 s (star_tracker.md M2)."""
    assert optimal_exposure_s(228.6 * ARCSEC_RAD) == pytest.approx(0.752, abs=0.001)
    assert optimal_exposure_s(212.9 * ARCSEC_RAD) == pytest.approx(0.807, abs=0.001)
    assert smear_loss_mag(228.6 * ARCSEC_RAD, 0.75) == 0.0
    assert smear_loss_mag(228.6 * ARCSEC_RAD, 2.0) == pytest.approx(1.06, abs=0.005)
    # About the boresight a star trails 0.055 of the rate (the RMS lever arm of a 7.81° field).
    assert trail_rate(0.0, 100.0) == pytest.approx(5.5) and trail_rate(3.0, 0.0) == 3.0


def test_recognition_failure_is_the_specs_shape():
    """physics.md §6 item 4: p = 1 − (1 − 0.3·e^−(n−3)/1.5)·(1 − 0.01)^others."""
    assert recognition_failure(3, 0, 0.3, 1.5, 0.01) == pytest.approx(0.3)
    assert recognition_failure(9, 0, 0.3, 1.5, 0.01) == pytest.approx(0.3 * math.exp(-4.0))
    assert recognition_failure(10, 5, 0.3, 1.5, 0.01) == pytest.approx(1 - (1 - 0.3 * math.exp(-7 / 1.5)) * 0.99 ** 5)


def test_hits_are_points_and_tracks_of_one_to_fifty_pixels():
    """star_tracker.md M5: footprints 1 to 40–50 pixels; grazing protons through the side make longer ones."""
    (side_mean, side_var), (lens_mean, lens_var) = hit_footprint_moments()
    assert 1.0 <= lens_mean < side_mean <= 50.0 and side_var > lens_var > 0.0
    # ≈ 1024 pixels of buffer (4 KB at 4 bytes) hold ≈ 150–200 hits [D/A].
    assert 120 < 1024 / side_mean < 260


def test_precession_moves_the_pole_by_the_iau_1976_angle():
    """IAU 1976: θ = 2004.3109″·T − 0.42665″·T² …; the J2000 pole is θ away from the pole of date."""
    jd = 2451545.0 + 0.16 * 36525.0
    pole = precession_matrix(jd) @ np.array([0.0, 0.0, 1.0])
    theta = (2004.3109 * 0.16 - 0.42665 * 0.16 ** 2 - 0.041833 * 0.16 ** 3) * ARCSEC_RAD
    assert math.acos(pole[2]) == pytest.approx(theta, rel=1e-9)
    assert np.allclose(precession_matrix(jd) @ precession_matrix(jd).T, np.eye(3))


def _random_axes(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(4, n))
    return rotation_matrices(q / np.linalg.norm(q, axis=0))


def test_the_real_sky_is_clustered_where_poisson_is_not(sky):
    """star_tracker.md §6.7, 6000 random 7.81° fields of the 8350-star catalogue: mean 12.4 stars, fewer than 3 in
    0.37 % (Poisson with the same mean: 0.04 %). Tolerance: the binomial spread of 6000 fields (≈ ±0.08 %) and
    of the mean (≈ ±0.1 star)."""
    stars = sky.stars_in_fields(_random_axes(6000, 1), math.radians(7.81) / 2.0, 8350)
    counts = np.bincount(stars.field, minlength=6000)
    assert counts.mean() == pytest.approx(12.4, abs=0.3)
    assert 0.0015 < np.mean(counts < 3) < 0.007
    # The field's square: no star beyond the half-width on either axis.
    assert np.abs(stars.u_rad).max() <= math.radians(7.81) / 2.0 and np.abs(stars.v_rad).max() <= math.radians(3.905)


def test_a_sky_index_serves_the_skies_of_other_dates(monkeypatch):
    """A campaign's tasks share one sky index (sky.INDEX_MARGIN_RAD, 0.1°): a sky four years on (≈ 200″ of
    precession) takes the index built for the first, whose cells hold every star the later sky's own cells would
    hold; 6000 random 7.81° fields see the same stars through it as through an index of the later sky's own; a
    sky sixty years on (≈ 0.8°) builds its own."""
    from scipy.spatial import cKDTree

    monkeypatch.setattr(sky_module, "_SHARED_INDEXES", {})
    half_width, date = math.radians(7.81) / 2.0, float(EPOCH.julian_date_tt(0.0))
    first, later = Sky(date), Sky(date + 4 * 365.25)
    start, stars = first.index(half_width)
    assert later.index(half_width)[1] is stars
    reach = math.atan(math.sqrt(2.0) * math.tan(half_width)) + sky_module._CELL_RADIUS_RAD  # without the margin
    needed = cKDTree(later.direction_eci.T).query_ball_point(sky_module._cell_centres().T, 2.0 * math.sin(reach / 2))
    assert all(np.isin(cell, stars[start[c]:start[c + 1]]).all() for c, cell in enumerate(needed))
    axes = _random_axes(6000, 2)
    shared = later.stars_in_fields(axes, half_width)
    monkeypatch.setattr(sky_module, "_SHARED_INDEXES", {})
    own = Sky(date + 4 * 365.25)
    assert own.index(half_width)[1] is not stars
    alone = own.stars_in_fields(axes, half_width)
    for name in ("field", "star", "u_rad", "v_rad", "hp_mag"):
        np.testing.assert_array_equal(getattr(shared, name), getattr(alone, name))
    assert shared.star.size > 50000
    assert Sky(date + 60 * 365.25).index(half_width)[1] is not own.index(half_width)[1]


def _tracker(sky, radiation, **options) -> StarTracker:
    return StarTracker(TrackerParameters(**options), KONDOR, EPOCH, seed=4, sky=sky, radiation=radiation)


def _orbit_frames(tracker: StarTracker, seconds: float, step_s: float = 1.0, start_s: float = 0.0):
    t = start_s + np.arange(0.0, seconds, step_s)
    q = np.tile([[0.0], [0.0], [0.0], [1.0]], t.size)
    return t, q, tracker.measure(t, q, np.zeros((3, t.size)))


class StillOrbit:
    """An 'orbit' whose orbital frame stays put in ECI: a constant attitude keeps the same stars in the field."""

    def state_eci(self, t_s):
        n = np.size(t_s)
        return np.tile([[7e6], [0.0], [0.0]], n), np.tile([[0.0], [1e-6], [0.0]], n)


def test_accuracy_comes_from_the_stars_in_the_field(sky):
    """physics.md §6 item 5: σ/√n across the boresight, σ/(r_rms·√n) about it; half the variance stays with the
    stars. One field held still over 400 frames: the spread about the field's bias is σ·√½/√n across and
    σ·√½/(r_rms·√n) about (within 12 %: 400 frames give ±3.5 % on a standard deviation, and the fit's
    weights are not exactly equal), and a second run of frames keeps the same bias."""
    tracker = StarTracker(TrackerParameters(trapped="off", sun_exclusion_rad=0.0, moon_exclusion_rad=0.0,
                                            earth_limb_exclusion_rad=0.0, geometry_failure_3=0.0,
                                            false_object_failure=0.0, rank_scatter_mag=0.0),
                          StillOrbit(), EPOCH, seed=3, sky=sky)
    q = np.tile([[0.3], [0.1], [-0.2], [0.927]] / np.linalg.norm([0.3, 0.1, -0.2, 0.927]), 400)
    first = tracker.measure(np.arange(400.0), q, np.zeros((3, 400)))
    later = tracker.measure(1e5 + np.arange(400.0), q, np.zeros((3, 400)))
    assert np.all(first.outcome == Outcome.OK) and len(set(first.used.tolist())) == 1
    n = int(first.used[0])
    # The measured attitude is the true one turned by the error (body axes; the boresight is body +Z).
    error = rotation_vector_from_quaternion(quaternion_product(quaternion_conjugate(q), first.q_measured))
    error_later = rotation_vector_from_quaternion(quaternion_product(quaternion_conjugate(q), later.q_measured))
    sigma = 9.5 * ARCSEC_RAD
    across = np.std(error[:2], axis=1)
    assert across == pytest.approx([sigma * math.sqrt(0.5 / n)] * 2, rel=0.12)
    # The stars used: the n brightest catalogue stars of the field.
    pointing = tracker.pointing(q[:, :1], np.zeros((3, 1)), tracker.orbit_environment(np.zeros(1)))
    stars = sky.stars_in_fields(pointing.axes_eci, math.radians(7.81) / 2.0, 8350)
    order = np.argsort(stars.hp_mag, kind="stable")[:n]
    u, v = stars.u_rad[order], stars.v_rad[order]
    r_rms = math.sqrt(np.mean((u - u.mean()) ** 2 + (v - v.mean()) ** 2))
    assert np.std(error[2]) == pytest.approx(sigma * math.sqrt(0.5 / n) / r_rms, rel=0.12)
    # The bias: ±σ·√½/√n (one draw per field); the two runs' means agree to their own spread (±5 % of it).
    bias = error[:2].mean(axis=1)
    assert np.abs(bias - error_later[:2].mean(axis=1)).max() < 0.3 * sigma * math.sqrt(0.5 / n)


def test_an_orbit_of_kondor_gives_a_few_arcseconds_and_says_why_it_gives_none(sky, radiation):
    """An orbit nadir pointing: 3″ across in the median field (physics.md §6 item 5; ±30 %: the fields of one
    orbit), no rate ceiling at the orbital rate, and every frame without attitude has a reason."""
    tracker = _tracker(sky, radiation, trapped="off")
    t, q, frames = _orbit_frames(tracker, KONDOR.period_s)
    ok = frames.outcome == Outcome.OK
    assert 0.7 < ok.mean() < 0.99 and not np.any(frames.outcome == Outcome.RATE_TOO_HIGH)
    assert np.all(np.isnan(frames.q_measured[:, ~ok])) and np.all(np.isfinite(frames.q_measured[:, ok]))
    tracker_error = 2.0 * frames.q_measured[:2, ok]  # small rotation (the true attitude is the identity)
    assert np.median(np.abs(tracker_error), axis=1) / 0.6745 == pytest.approx([3 * ARCSEC_RAD] * 2, rel=0.3)
    assert set(np.unique(frames.outcome[~ok]).tolist()) <= {o.value for o in REASON_ORDER}


def test_the_same_frame_time_gives_the_same_frame(sky, radiation):
    """Draws keyed by the frame's time: a frame measured alone is the frame measured among others."""
    tracker = _tracker(sky, radiation, geometry_failure_3=0.9, geometry_failure_scale=8.0)
    t, q, frames = _orbit_frames(tracker, 600.0)
    for k in (0, 17, 333, 599):
        alone = tracker.measure(t[k:k + 1], q[:, k:k + 1], np.zeros((3, 1)))
        assert alone.outcome[0] == frames.outcome[k]
        np.testing.assert_array_equal(alone.q_measured[:, 0], frames.q_measured[:, k])
    other = StarTracker(TrackerParameters(geometry_failure_3=0.9, geometry_failure_scale=8.0), KONDOR, EPOCH, seed=5,
                        sky=sky, radiation=radiation)
    assert not np.array_equal(other.measure(t, q, np.zeros((3, t.size))).outcome, frames.outcome)


def test_the_sun_near_the_boresight_is_an_exclusion(sky, radiation):
    """physics.md §6 item 8: Sun within 30° of the boresight → exclusion; the boresight turned onto the Sun."""
    tracker = _tracker(sky, radiation, trapped="off")
    t = np.array([1000.0])
    jd = EPOCH.julian_date_tt(t)
    from pmv_ros.physics.orbit.ephemeris import sun_direction_eci
    from pmv_ros.physics.orbit.two_body import orbital_frame_from_state
    from scipy.spatial.transform import Rotation
    position, velocity = KONDOR.state_eci(t)
    orbital = orbital_frame_from_state(position, velocity)[:, :, 0]
    sun_in_orbital = orbital.T @ sun_direction_eci(jd)[:, 0]
    rotation, _ = Rotation.align_vectors([sun_in_orbital], [[0.0, 0.0, 1.0]])  # body +Z onto the Sun
    q = rotation.as_quat().reshape(4, 1)
    frames = tracker.measure(t, q, np.zeros((3, 1)))
    assert frames.outcome[0] == Outcome.EXCLUSION


def test_protons_hit_in_the_saa_as_the_ap8_flux_says(sky, radiation):
    """physics.md §6 item 6: N = A·t_exp·[J(>45)/4·cos²35° + J(>100)/4·sin²35°]; at the SAA core (26°S, 50°W,
    500 km, AP8MAX: J(>45) 378, J(>100) 280 cm⁻² s⁻¹, star_tracker.md §6.7) that is ≈ 43 hits in 0.75 s
    (the grid within 5 % of aep8 there), and no hit at 60°N."""
    flux45, flux100, shell = radiation.environment(np.radians([-26.0, 60.0]), np.radians([-50.0, 0.0]),
                                                   np.array([500e3, 500e3]))
    assert flux45[0] == pytest.approx(378.2, rel=0.05) and flux100[0] == pytest.approx(280.4, rel=0.05)
    assert flux45[1] == 0.0 and shell[0] < 1.3 and shell[1] > 3.0
    expected = CCD_AREA_CM2 * 0.75 * (378.2 / 4 * math.cos(math.radians(35)) ** 2
                                       + 280.4 / 4 * math.sin(math.radians(35)) ** 2)
    assert expected == pytest.approx(43.6, abs=0.1)
    draws = Draws(1)
    counts = draws.poisson(np.full(20000, expected), 6, np.arange(20000), 0)
    assert counts.mean() == pytest.approx(expected, rel=0.01)


def test_a_solar_event_reaches_only_where_the_shell_is_open(sky, radiation):
    """physics.md §6 item 7: in LEO solar protons reach where L ≥ 7.1; near the equator never."""
    _, _, shell = radiation.environment(np.radians([0.0, 80.0, -75.0]), np.radians([0.0, 0.0, 120.0]),
                                        np.full(3, 835e3))
    assert shell[0] < 1.2 and shell[1] > 7.1 and shell[2] > 7.1


def test_an_ideal_tracker_gives_the_truth_outside_outages():
    tracker = StarTracker(TrackerParameters(ideal=True, outages=((5.0, 7.0),)), KONDOR, EPOCH)
    t = np.arange(10.0)
    q = np.tile([[0.0], [0.6], [0.0], [0.8]], 10)
    q[:, 3] = np.nan
    frames = tracker.measure(t, q, np.zeros((3, 10)))
    assert frames.outcome.tolist() == [0, 0, 0, 7, 0, 2, 2, 0, 0, 0]
    np.testing.assert_array_equal(frames.q_measured[:, [0, 9]], q[:, [0, 9]])


@pytest.mark.parametrize("name, value", [("exposure_s", 0.0), ("catalogue_stars", 2), ("trapped", "maybe"),
                                         ("boresight_body", (0.0, 0.0, 0.0)), ("outages", ((5.0, 1.0),))])
def test_bad_configuration_is_refused_in_one_line(name, value):
    with pytest.raises(ValueError, match=name.split("_")[0].rstrip("s")) as caught:
        TrackerParameters(**{name: value})
    assert "\n" not in str(caught.value)
