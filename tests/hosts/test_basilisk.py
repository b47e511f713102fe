"""The PMV in Basilisk (issue 31): the same instrument on another host, its monitor, a closed loop through it.

Short runs (a few hundred steps each); the full-orbit figures of README "In Basilisk" come from
examples/basilisk_figures.py. Every test name carries ``basilisk``: ``pytest -k basilisk`` runs them all.
"""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest

pytest.importorskip("Basilisk", reason="bsk (Basilisk) is not installed: pip install pmv_ros[basilisk]")

from Basilisk.utilities import RigidBodyKinematics  # noqa: E402
from scipy.signal import lsim  # noqa: E402

from flights import REPO  # noqa: E402
from pmv_ros.hosts.basilisk import (DCM_CB_HILL, PmvHorizonSensor, attitude_in_orbital,  # noqa: E402
                                    kondor_scenario, sigma_from_roll_pitch_yaw)
from pmv_ros.hosts.basilisk.replay import flight_summary, replay_states  # noqa: E402
from pmv_ros.hosts.basilisk.scenario import GAINS, INERTIA_KG_M2  # noqa: E402
from pmv_ros.physics.attitude import roll_pitch_yaw_from_quaternion  # noqa: E402
from pmv_ros.physics.constants import ARCMIN_RAD  # noqa: E402
from pmv_ros.physics.instrument.oblateness import closed_form_oblateness  # noqa: E402
from pmv_ros.physics.orbit.two_body import orbit_angles_from_state, orbital_frame_from_state  # noqa: E402

pytestmark = [pytest.mark.multi_process]

KONDOR = str(REPO / "config" / "kondor.yaml")
#: The geometric instrument: the ideal detector sees the 40 km layer's horizon on GRS80, so its whole error is
#: the oblateness of the ray geometry; no Sun or Moon check (half the cost of a sample, which is per step here).
GEOMETRIC = {"sensor.detector": "ideal", "radiance.source": "uniform", "sensor.bright_body_exclusion_deg": 0.0}


def recorded(scenario):
    states = scenario.states
    return states.timesWritten(), states.r_BN_N, states.v_BN_N, states.sigma_BN


def test_basilisk_frames_are_basilisks_own_and_the_hill_frame_reads_zero():
    rng = np.random.default_rng(31)
    r, v = np.array([6.2e6, 2.1e6, 1.7e6]), np.array([-2.5e3, 4.1e3, 5.6e3])
    for sigma in rng.normal(scale=0.3, size=(5, 3)):
        # attitude_in_orbital against Basilisk's MRP2C and pmv_ros's orbital frame, built by hand: [OC] = [ON][NB][BC].
        frame = orbital_frame_from_state(r, v)
        expected = frame.T @ RigidBodyKinematics.MRP2C(sigma).T @ DCM_CB_HILL.T
        q = attitude_in_orbital(r, v, sigma, DCM_CB_HILL)[:, 0]
        x, y, z, w = q
        matrix = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                           [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                           [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        np.testing.assert_allclose(matrix, expected, atol=1e-14)
        # And back: sigma_from_roll_pitch_yaw is its inverse (the short MRP set).
        back = sigma_from_roll_pitch_yaw(*roll_pitch_yaw_from_quaternion(q), r, v, DCM_CB_HILL)[0]
        np.testing.assert_allclose(RigidBodyKinematics.MRP2C(back), RigidBodyKinematics.MRP2C(sigma), atol=1e-14)
    # The Hill frame of hillPoint (1 radial, 2 along track, 3 normal) is the orbital frame for DCM_CB_HILL.
    frame = orbital_frame_from_state(r, v)
    hill_n = np.column_stack([frame[:, 2], frame[:, 0], frame[:, 1]])
    on_hill = attitude_in_orbital(r, v, RigidBodyKinematics.C2MRP(hill_n.T), DCM_CB_HILL)
    assert np.allclose(roll_pitch_yaw_from_quaternion(on_hill), 0.0, atol=1e-14)


@pytest.mark.parametrize("mode", ["direct", "batch"])
def test_basilisk_module_reads_what_pmv_ros_senses_of_the_very_same_states(mode):
    # Basilisk flies 15 s of the Kondor preset (two-body, nadir by its FSW on truth; 60 s in batches of 20 s,
    # which cost little); the module's readings and
    # its monitor's statistics equal the recorded states replayed through the runtimes the way the campaign's
    # flight feeds them (one sample per step, or the module's batches), to 1e-9′ and 1e-6′.
    scenario = kondor_scenario(KONDOR, pmv=mode, pointing="truth", batch_s=20.0)
    duration_s = 15.0 if mode == "direct" else 60.0
    scenario.run(duration_s)
    times, r, v, sigma = recorded(scenario)
    readings = scenario.readings
    # The module took the run's epoch from Basilisk's EpochMsg (the scenario writes the preset's): the same instant.
    assert scenario.pmv.values.sensor["sim.epoch_utc"] == "2013-09-10T00:00:00.000000Z"
    samples = replay_states(scenario.pmv.values, times, r, v, sigma, DCM_CB_HILL,
                            call_every_ns=20_000_000_000 if mode == "batch" else None)
    steps = round(duration_s * 10) + 1  # every 0.1 s step from 0 on, the sample at 0 included
    assert len(readings) == len(samples) == steps
    assert np.array_equal(readings.times(), np.arange(steps) * 100_000_000)
    for ours, theirs in (("roll_CO", "roll_rad"), ("pitch_CO", "pitch_rad"), ("rollUncorrected_CO",
                         "roll_uncorrected_rad"), ("pitchUncorrected_CO", "pitch_uncorrected_rad")):
        module, replayed = getattr(readings, ours), np.array([getattr(s, theirs) for s in samples])
        assert np.array_equal(np.isnan(module), np.isnan(replayed))
        assert np.nanmax(abs(module - replayed)) <= 1e-9 * ARCMIN_RAD
    assert np.array_equal(readings.chordStatus, np.array([s.chord_status for s in samples]))
    # Nadir pointing on truth: the body is on the local vertical to far below an arcsecond; the sensor reads
    # arcminutes (its methodical error), valid throughout on this stretch.
    assert np.abs(readings.trueRoll_CO).max() < 0.01 * ARCMIN_RAD
    assert readings.valid.all() and np.abs(readings.roll_CO).max() > 0.1 * ARCMIN_RAD
    module, flight = scenario.monitor.summary(), flight_summary(scenario.pmv.values, samples)
    for channel in ("roll", "pitch", "meridional"):
        a, b = module.channel(channel), flight.channel(channel)
        # The last ≈ 2 s wait for the star tracker's next frame (a frame a second, published 0.875 s after it).
        assert a.count == b.count >= steps - 20
        assert abs(a.mean_rad - b.mean_rad) <= 1e-6 * ARCMIN_RAD
        assert abs(a.sigma_rad - b.sigma_rad) <= 1e-6 * ARCMIN_RAD


def test_basilisk_parameters_are_the_presets_through_the_same_guards():
    with pytest.raises(ValueError, match=r"sensor\.rate_hz = 1000\.0 is outside the allowed range"):
        PmvHorizonSensor(KONDOR, {"sensor.rate_hz": 1000.0})
    with pytest.raises(ValueError, match="did you mean 'sensor.rate_hz'"):
        PmvHorizonSensor(KONDOR, {"sensor.rate_hz_": 10.0})
    with pytest.raises(ValueError, match="follows the spacecraft Basilisk flies"):
        PmvHorizonSensor(KONDOR, {"orbit.source": "tle"})
    with pytest.raises(ValueError, match="sim.epoch_utc"):
        PmvHorizonSensor(KONDOR, {"sim.epoch_utc": "yesterday"})
    with pytest.raises(ValueError, match="dcm_CB is not a rotation"):
        PmvHorizonSensor(KONDOR, dcm_CB=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="params file"):
        PmvHorizonSensor(str(REPO / "config" / "no_such_preset.yaml"))
    # A good one: the preset's values, following Basilisk's spacecraft on Basilisk's clock.
    sensor = PmvHorizonSensor(KONDOR, {"sensor.rate_hz": 5.0})
    assert sensor.values.sensor["sensor.rate_hz"] == 5.0 and sensor.values.sensor["seed"] == 1
    assert sensor.values.sensor["attitude.source"] == sensor.values.sensor["orbit.source"] == "follow"


def _through_the_loop(axis: int, error, t):
    """The true angle mrpFeedback settles a body to when its attitude is measured with ``error``: −H(s)·error,
    H = (K/4) / (I s² + P s + K/4) for small angles (gyro rates from truth, the reference's rate fed forward)."""
    inertia, k, p = INERTIA_KG_M2[axis][axis], GAINS["K"], GAINS["P"]
    return lsim(([k / 4.0], [inertia, p, k / 4.0]), -np.asarray(error), t - t[0])[1]


def test_basilisk_closed_loop_through_the_pmv_holds_minus_the_oblateness_and_compensation_removes_it():
    # mrpFeedback fed the PMV's roll and pitch (yaw and rate from truth), 200 s at 5 Hz from the ascending node.
    # Without on-board compensation the true attitude settles to minus the oblateness (physics.md §2.1) the way
    # the loop passes a slow error, −H(s)·model: within 0.2′ — the ideal detector sees the ray geometry of the
    # 40 km layer, which the closed form follows to ≈ 0.05′ (σ) along this arc, 0.15′ at most. With it, the
    # body stays within the same 0.2′ of the local vertical while the oblateness grows past 2′.
    true_pitch = {}
    for compensation in (False, True):
        scenario = kondor_scenario(KONDOR, {**GEOMETRIC, "sensor.rate_hz": 5.0,
                                            "sensor.oblateness_compensation": compensation},
                                   pmv="direct", pointing="pmv", step_s=0.2)
        scenario.run(200.0)
        readings = scenario.readings
        t = readings.times() * 1e-9
        times, r, v, _ = recorded(scenario)
        index = np.searchsorted(times, readings.times())
        u, inclination, altitude = orbit_angles_from_state(r[index].T, v[index].T)
        _, model_roll, model_pitch = closed_form_oblateness(u, altitude, inclination)
        assert readings.valid.all() and scenario.nav.heldReadings == 0
        for axis, true, sensed, model in ((1, readings.trueRoll_CO, readings.roll_CO, model_roll),
                                          (2, readings.truePitch_CO, readings.pitch_CO, model_pitch)):
            # The loop is closed through what the PMV measured: the true attitude is −H(s)·(sensed − true).
            assert np.abs(true - _through_the_loop(axis, sensed - true, t)).max() < 0.01 * ARCMIN_RAD
            if not compensation:
                assert np.abs(true - _through_the_loop(axis, model, t)).max() < 0.2 * ARCMIN_RAD
            else:
                assert np.abs(true).max() < 0.2 * ARCMIN_RAD
        true_pitch[compensation] = readings.truePitch_CO
        if not compensation:
            assert np.abs(model_pitch).max() > 2.0 * ARCMIN_RAD
    assert np.abs(true_pitch[False][-1]) > 10 * np.abs(true_pitch[True][-1])


def test_basilisk_is_imported_by_its_host_only_and_the_host_runs_without_ros():
    # The core imports without Basilisk (tests/system/test_layers.py checks the source); the host imports with
    # ROS blocked: a Basilisk user needs no ROS.
    script = textwrap.dedent("""
        import importlib, sys

        class NoRos:
            def find_spec(self, name, path=None, target=None):
                root = name.split(".")[0]
                blocked = ("rclpy", "rosidl_runtime_py", "builtin_interfaces", "pmv_msgs_shim")
                if root in blocked or root.endswith("_msgs"):
                    raise ImportError(f"blocked for this test: {name}")
                return None

        sys.meta_path.insert(0, NoRos())
        import pmv_ros.runtime.flight, pmv_ros.apps.report
        assert "Basilisk" not in sys.modules, "the core imported Basilisk"
        import pmv_ros.hosts.basilisk
        assert "Basilisk" in sys.modules and "rclpy" not in sys.modules
        print("ok")
    """)
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "ok"
