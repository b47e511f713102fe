"""The weather reaches a chord as a continuous field along its line of sight (physics.md §3.2 item 3).

The chain interpolates the disc radiance through samples at fixed inward
angles (chain.DISC_SAMPLE_INWARD_RAD); the sensor keeps the environment's
random fields on a (time, azimuth) grid along the horizon and interpolates
(pmv_ros/physics/instrument/horizon_fields.py). These tests check the
interpolation against exact forms and the grid against one at every sample
(that a reading does not depend on how samples are grouped:
tests/physics/test_sample_grouping.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics import chain
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.instrument.correction import calibrated_correction_table
from pmv_ros.physics.environment import EnvironmentParameters
from pmv_ros.physics.orbit.two_body import CircularOrbit
from pmv_ros.physics.instrument.sensor import ChainDetector, RadianceConfig, SensorConfig, SensorModel

ALTITUDE_M = 835e3
PHI0, SLOPE = chain.sphere_chord(ALTITUDE_M)
START = float(chain.scan_start_nadir_angle(PHI0, SLOPE)) + math.radians(1.0)
TABLE = calibrated_correction_table(ALTITUDE_M)


def sense(radiance, **kwargs):
    return chain.sense_horizon_chords(np.full(np.shape(radiance), PHI0), SLOPE, radiance, scan_start_nadir_rad=START,
                                      correction=TABLE, **kwargs)


def test_the_profile_passes_through_the_samples():
    rng = np.random.default_rng(3)
    b_m = rng.uniform(1.0, 4.0, 50)
    samples = rng.uniform(1.0, 4.0, (50, 3))
    profile = chain.disc_sample_profile(np.array((0.0,) + chain.DISC_SAMPLE_INWARD_RAD), b_m, samples)
    np.testing.assert_allclose(profile[:, 0], b_m, atol=1e-12)
    np.testing.assert_allclose(profile[:, 1:], samples, atol=1e-9)


def test_uniform_samples_change_nothing():
    # Samples equal to B_m describe the uniform disc: the same readings as no samples (to round-off).
    radiance = np.linspace(1.0, 4.0, 13)
    plain = sense(radiance)
    sampled = sense(radiance, disc_samples_ru=np.repeat(radiance[:, None], 3, axis=1))
    np.testing.assert_allclose(sampled.gam_rad, plain.gam_rad, atol=1e-9 * ARCMIN_RAD)
    np.testing.assert_allclose(sampled.del_rad, plain.del_rad, atol=1e-9 * ARCMIN_RAD)


def test_samples_of_a_surface_gradient_reproduce_model_b():
    # A radiance linear in ground distance (Model B) sampled where the sample lines of sight hit the ground:
    # the interpolant is the same basis the gradient path uses, so the readings agree to the fit of d(x)
    # (< 40 m of ground distance, i.e. < 0.01′ here).
    gradient = np.array([-4e-7, -1e-7, 2e-7, 4e-7])  # r.u. per m
    b_m = np.full(4, 2.4)
    distance = chain.chord_ground_distance(PHI0 - np.asarray(chain.DISC_SAMPLE_INWARD_RAD), PHI0, SLOPE)
    samples = b_m[:, None] + gradient[:, None] * distance[None, :]
    by_gradient = sense(b_m, gradient_ru_per_m=gradient)
    by_samples = sense(b_m, disc_samples_ru=samples)
    np.testing.assert_allclose(by_samples.gam_rad, by_gradient.gam_rad, atol=0.01 * ARCMIN_RAD)
    np.testing.assert_allclose(by_samples.sensed_horizon_nadir_rad, by_gradient.sensed_horizon_nadir_rad,
                               atol=0.01 * ARCMIN_RAD)


def test_bad_samples_are_bad_input_of_that_chord_only():
    samples = np.full((3, 3), 2.4)
    samples[1, 2] = np.nan
    readings = sense(np.full(3, 2.4), disc_samples_ru=samples)
    assert list(readings.status) == [chain.DetectionStatus.OK, chain.DetectionStatus.INVALID_INPUT,
                                     chain.DetectionStatus.OK]
    with pytest.raises(ValueError, match="disc_samples_ru"):
        sense(np.full(3, 2.4), disc_samples_ru=np.ones((3, 5)))


def _model(grid_s=None, synoptic=0.5, height_radius_m=100e3):
    environment = EnvironmentParameters(relative_variability=0.25, synoptic_fraction=synoptic,
                                        height_correlation_radius_m=height_radius_m, seed=4)
    orbit = CircularOrbit(ALTITUDE_M, math.radians(98.8))
    detector = ChainDetector(ALTITUDE_M, RadianceConfig(source="environment", environment=environment,
                                                        field_grid_s=grid_s), TABLE)
    return SensorModel(orbit, SensorConfig(), detector)


def test_the_field_grid_agrees_with_a_grid_at_every_sample():
    # 10 Hz for 5 minutes: the default grid (weather every 4.2 s, layer height every 1.4 s at R_h = 100 km, a
    # cubic through four time nodes) against one node at every sample time (0.1 s). The horizon point moves
    # ≈ 28 km between weather nodes against scales of ≥ 300 km, ≈ 10 km between height nodes against 100 km:
    # design/field_grid_accuracy.py measures ≤ 0.012′ for the presets; 0.03′ and 0.005′ rms here, far below
    # the ≈ 3′ the environment itself makes.
    t = np.arange(0.0, 300.0, 0.1)
    q = np.tile(np.array([[0.0], [0.0], [0.0], [1.0]]), t.size)
    gridded = _model().sense(t, q)
    exact = _model(grid_s=0.1).sense(t, q)
    difference = np.abs(gridded.sensed_pitch_rad - exact.sensed_pitch_rad) / ARCMIN_RAD
    assert np.max(difference) < 0.03 and np.sqrt(np.mean(difference**2)) < 0.005
    assert np.std(exact.sensed_pitch_rad - np.mean(exact.sensed_pitch_rad)) / ARCMIN_RAD > 0.3


@pytest.mark.parametrize("wavelength_km, low, high", [(2000.0, 0.7, 2.0), (8000.0, 0.0, 0.6)])
def test_the_working_curve_leaves_synoptic_zones_uncorrected(wavelength_km, low, high):
    """Why the calibration cannot reach the records' k ≈ 20 contrast (README, "The flight environment").

    A radiance wave along the line of sight, B(d) = 2.4·(1 + 0.1·cos(2πd/λ + φ)), over 16 phases φ: the
    RMS error of the corrected crossing against the uncorrected one. The curve corrects what the leading
    edge's slope measures, which near the horizon and ≈ 750 km inside enter with opposite signs, so for
    zones of 2000 km it corrects nothing (ratio ≈ 1); for a wave long against the ≈ 1400 km the samples
    span it works as on the rig.
    """
    phases = np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False)
    distance = chain.chord_ground_distance(PHI0 - np.asarray(chain.DISC_SAMPLE_INWARD_RAD), PHI0, SLOPE)
    k = 2.0 * math.pi / (wavelength_km * 1e3)
    b_m = 2.4 * (1.0 + 0.1 * np.cos(phases))
    samples = 2.4 * (1.0 + 0.1 * np.cos(k * distance[None, :] + phases[:, None]))
    flat = sense(np.full(16, 2.4))
    waved = sense(b_m, disc_samples_ru=samples)
    corrected = np.sqrt(np.mean((waved.sensed_horizon_nadir_rad - flat.sensed_horizon_nadir_rad) ** 2))
    uncorrected = np.sqrt(np.mean((waved.sensed_horizon_nadir_uncorrected_rad
                                   - flat.sensed_horizon_nadir_uncorrected_rad) ** 2))
    assert low < corrected / uncorrected < high


@pytest.mark.parametrize("wavelength_km, tolerance_arcmin", [(2000.0, 0.1), (1000.0, 0.5)])
def test_three_samples_against_the_dense_line_of_sight(wavelength_km, tolerance_arcmin):
    """The sampled disc against the continuous one, through the general chain (chain.sense_sampled_chords).

    A radiance wave along the ground, B(d) = 2.4·(1 + 0.1·cos(2πd/λ + φ)), 8 phases: the corrected crossing
    from the three samples against the same wave evaluated at every point of the scan. Measured RMS
    deviation 0.04′ at λ = 2000 km (signal 2.6′), 0.34′ at 1000 km (signal 1.7′), 0.8′ at 700 km: the
    sampling resolves the synoptic scales and the red background down to ≈ 1000 km; finer radial
    structure is what it does not resolve (README, "The flight environment").
    """
    from pmv_ros.physics.radiance import atmosphere_radiance

    phases = np.linspace(0.0, 2.0 * math.pi, 8, endpoint=False)
    k = 2.0 * math.pi / (wavelength_km * 1e3)

    def profile(amplitude):
        def radiance(nadir):
            h = chain.chord_tangent_height(nadir, PHI0, SLOPE)
            d = np.nan_to_num(chain.chord_ground_distance(nadir, PHI0, SLOPE))
            b_m = 2.4 * (1.0 + amplitude * np.cos(phases))[:, None] + 0.0 * h
            disc = 2.4 * (1.0 + amplitude * np.cos(k * d + phases[:, None]))
            return np.where(h > 0.0, atmosphere_radiance(np.maximum(h, 0.0), b_m), disc)
        return chain.sense_sampled_chords(radiance, np.full(phases.size, START), correction=TABLE, oversampling=4)

    dense = profile(0.1).sensed_horizon_nadir_rad - profile(0.0).sensed_horizon_nadir_rad
    distance = chain.chord_ground_distance(PHI0 - np.asarray(chain.DISC_SAMPLE_INWARD_RAD), PHI0, SLOPE)
    samples = 2.4 * (1.0 + 0.1 * np.cos(k * distance[None, :] + phases[:, None]))
    sampled = (sense(2.4 * (1.0 + 0.1 * np.cos(phases)), disc_samples_ru=samples).sensed_horizon_nadir_rad
               - sense(np.full(phases.size, 2.4)).sensed_horizon_nadir_rad)
    assert np.sqrt(np.mean((sampled - dense) ** 2)) / ARCMIN_RAD < tolerance_arcmin
    assert np.sqrt(np.mean(dense**2)) / ARCMIN_RAD > 1.0  # the wave does move the crossing
