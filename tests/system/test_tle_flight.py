"""A spacecraft flown from its element set through the sensor node, ``pmv simulate``, ``pmv campaign``.

Issue 21 "Must show": the radius of ``/orbit/odometry`` of a TLE run agrees
with an independent SGP4 propagation of the same element set to < 1 km;
period and inclination to 1e-3 relative; malformed element sets give one
line (the node exits 1, the CLI 2); an SGP4 error mid-run stops the output
with an ERROR, never a traceback. (The radius over a whole day is checked
on the same orbit object without ROS in tests/physics/test_tle_orbit.py.)
"""

from __future__ import annotations

import math
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pytest

from children import child_env, domain_id
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from sgp4.api import WGS72, Satrec, jday

import pmv_msgs_shim as shim
from pmv_ros.cli import main as pmv_main
from pmv_ros.nodes.sensor_node import SensorNode
from pmv_ros.physics.orbit.tle import make_element_set, tle_checksum
from pmv_ros.runtime.common import assembly

pytestmark = [pytest.mark.multi_process]

REPO = Path(__file__).resolve().parents[2]
PRESET = REPO / "config" / "meteor_m2_tle.yaml"
VENV_BIN = Path(sys.executable).parent
EPOCH = datetime(2016, 11, 11, tzinfo=timezone.utc)


def preset_document() -> dict:
    return yaml.safe_load(PRESET.read_text())


def preset_lines() -> tuple[str, str]:
    orbit = preset_document()["/**"]["ros__parameters"]["orbit"]  # shared by the sensor and the star tracker
    return orbit["tle_line1"], orbit["tle_line2"]


def write_preset(path: Path, line1: str, line2: str) -> Path:
    document = preset_document()
    orbit = document["/**"]["ros__parameters"]["orbit"]
    orbit["tle_line1"], orbit["tle_line2"] = line1, line2
    path.write_text(yaml.safe_dump(document))
    return path


def independent_sgp4(line1, line2, start_utc: datetime, t_s):
    """python-sgp4 on its own: TEME position and velocity (m, m/s) at ``start_utc + t_s``."""
    satrec = Satrec.twoline2rv(line1, line2, WGS72)
    jd, fr = jday(start_utc.year, start_utc.month, start_utc.day, start_utc.hour, start_utc.minute,
                  start_utc.second)
    errors, r, v = satrec.sgp4_array(np.full(np.shape(t_s), jd), fr + np.asarray(t_s) / 86400.0)
    assert not np.any(errors)
    return r.T * 1e3, v.T * 1e3


def ascending_nodes(t_s, z_m):
    k = np.flatnonzero((z_m[:-1] < 0.0) & (z_m[1:] >= 0.0))
    return t_s[k] - z_m[k] * (t_s[k + 1] - t_s[k]) / (z_m[k + 1] - z_m[k])


def tle_overrides(line1, line2, rate_hz: float) -> dict:
    return {"orbit.source": "tle", "orbit.tle_line1": line1, "orbit.tle_line2": line2,
            "sim.epoch_utc": "2016-11-11T00:00:00Z", "sim.fast_time": True, "sensor.rate_hz": rate_hz,
            "sensor.detector": "ideal", "sensor.bright_body_exclusion_deg": 0.0}


def run_sensor(harness, overrides: dict, ticks: int):
    """Step a fast-time sensor node ``ticks`` times; its odometry states and /diagnostics messages."""
    h = harness(SensorNode, overrides, external_drive=True)
    odometry = h.record(Odometry, "/orbit/odometry")
    diagnostics = h.record(DiagnosticArray, "/diagnostics")
    for tick in range(ticks):
        h.node.step()
        if tick % 40 == 39:  # the queues hold 100 messages
            h.drain()
    h.drain()
    return h, [shim.orbit_state_from_msg(m) for m in odometry], diagnostics


def test_odometry_of_an_element_set_run_matches_an_independent_sgp4(harness):
    line1, line2 = preset_lines()
    # 0.1 Hz for 3.6 h: two whole orbits of odometry (the ROS-free check covers a whole day).
    _, states, _ = run_sensor(harness, tle_overrides(line1, line2, 0.1), 1300)
    t = np.array([s.stamp_s for s in states])
    position = np.array([s.position_m for s in states]).T
    velocity = np.array([s.velocity_m_s for s in states]).T
    assert t.size == 1300 and states[0].frame_id == shim.ECI_FRAME
    reference, reference_velocity = independent_sgp4(line1, line2, EPOCH, t)
    # < 1 km (issue 21): a misplaced epoch by 1 s would already show as ≈ 10 m at e ≈ 0.001
    assert np.max(np.abs(np.linalg.norm(position, axis=0) - np.linalg.norm(reference, axis=0))) < 1e3
    # nodal period and inclination to 1e-3 relative, against SGP4 sampled densely on its own
    dense = np.arange(0.0, t[-1], 2.0)
    nodes = ascending_nodes(t, position[2])
    reference_nodes = ascending_nodes(dense, independent_sgp4(line1, line2, EPOCH, dense)[0][2])
    assert nodes.size >= 2
    assert abs(np.mean(np.diff(nodes)) / np.mean(np.diff(reference_nodes)) - 1.0) < 1e-3
    h, h_ref = np.cross(position, velocity, axis=0), np.cross(reference, reference_velocity, axis=0)
    inclination = np.mean(np.arccos(h[2] / np.linalg.norm(h, axis=0)))
    reference_inclination = np.mean(np.arccos(h_ref[2] / np.linalg.norm(h_ref, axis=0)))
    assert abs(inclination / reference_inclination - 1.0) < 1e-3


def first_failure_s(line1, line2, last_s: float, step_s: float = 1.0) -> float:
    satrec = Satrec.twoline2rv(line1, line2, WGS72)
    t = np.arange(0.0, last_s, step_s)
    errors, _, _ = satrec.sgp4_array(np.full(t.shape, satrec.jdsatepoch), satrec.jdsatepochF + t / 86400.0)
    return float(t[np.flatnonzero(errors)[0]])


#: An element set that SGP4 gives up on within minutes (B* = 0.1 at ≈ 230 km).
FAILING = make_element_set(EPOCH, 51.6, 0.0, 0.0, 0.0, 0.0, 16.2, bstar_per_earth_radius=0.1)


def test_an_sgp4_error_mid_run_stops_the_output_with_an_error(harness, monkeypatch):
    failure_s = first_failure_s(*FAILING, 3600.0)
    assert 60.0 < failure_s < 1000.0
    monkeypatch.setattr(assembly, "ORBIT_CHECK_S", 0.0)  # no start-up check: the error comes mid-run
    h, states, diagnostics = run_sensor(harness, tle_overrides(*FAILING, 1.0), int(failure_s) + 600)
    stamps = [s.stamp_s for s in states]
    # output up to the block that reaches the failure (blocks of 512 are computed ahead), none after
    assert 0 < len(stamps) < failure_s and max(stamps) < failure_s
    reports = [s for m in diagnostics for s in shim.health_from_msg(m).statuses
               if s.name == "pmv_ros/sensor_node: horizon"]
    errors = [s for s in reports if s.level == shim.Level.ERROR and "SGP4 error" in s.message]
    assert errors
    assert "no output from here on" in errors[-1].message
    assert int(dict(errors[-1].values)["skipped_orbit_error"]) > 0


def _child_env(log_dir: Path) -> dict:
    return child_env(log_dir, domain_id(0), discovery="OFF")  # it exits before it talks


def test_a_malformed_element_set_stops_the_node_with_one_line(tmp_path):
    line1, line2 = preset_lines()
    bad = write_preset(tmp_path / "bad.yaml", line1, line2[:68] + str((tle_checksum(line2) + 1) % 10))
    result = subprocess.run([str(VENV_BIN / "sensor_node"), "--ros-args", "--params-file", str(bad)],
                            env=_child_env(tmp_path / "log"), cwd=tmp_path, stdin=subprocess.DEVNULL,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert "orbit.tle_line2: checksum (column 69)" in lines[0]


def _shifted(line: str) -> str:
    moved = line[:17] + line[18:] + " "  # every field after column 17 one column to the left
    return moved[:68] + str(tle_checksum(moved))


#: Decays ≈ 4.8 days after its epoch: past the node's one-day start-up check, inside an 80-orbit run.
DECAYING = make_element_set(EPOCH, 51.6, 0.0, 0.0, 0.0, 0.0, 15.9, bstar_per_earth_radius=0.01)


@pytest.mark.parametrize("lines, arguments, words", [
    (lambda l1, l2: (_shifted(l1), l2), [], "tle_line1: column layout: column 18 must be blank"),
    (lambda l1, l2: DECAYING, ["--orbits", "80"], "SGP4 error 6 at t = "),
    (lambda l1, l2: (l1, l2), ["--epoch", "2018-01-01T00:00:00Z"], "days from the element set's epoch"),
])
def test_pmv_simulate_refuses_with_one_line(tmp_path, capsys, lines, arguments, words):
    config = write_preset(tmp_path / "preset.yaml", *lines(*preset_lines()))
    status = pmv_main(["simulate", "--config", str(config), "--quiet", *arguments])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert [line for line in err if line.startswith("pmv simulate: error:")] == [err[-1]]
    assert words in err[-1] and "Traceback" not in "\n".join(err)


def test_orbit_source_follow_is_refused_by_simulate_and_campaign(tmp_path, capsys):
    # A followed orbit is the user's odometry: the in-process main job and a campaign have none to follow.
    document = preset_document()
    document["/**"]["ros__parameters"]["orbit"]["source"] = "follow"
    (tmp_path / "follow.yaml").write_text(yaml.safe_dump(document))
    assert pmv_main(["simulate", "--config", str(tmp_path / "follow.yaml"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "orbit.source = follow: pmv simulate flies an orbit of its own" in err[0], err
    assert pmv_main(["campaign", "--config", str(tmp_path / "follow.yaml"), "--days", "1", "--seeds", "1",
                     "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "orbit.source = follow: a campaign flies an orbit of its own" in err[0], err


def test_campaign_days_count_from_the_element_sets_epoch(tmp_path):
    from pmv_ros.apps import campaign

    line1, line2 = DECAYING
    document = yaml.safe_load(write_preset(tmp_path / "decaying.yaml", line1, line2).read_text())
    assert campaign.parse_days("0-2,6", 2016, from_elements=True) == [0, 1, 2, 6]
    with pytest.raises(ValueError, match="outside the allowed range 0 … 365"):
        campaign.parse_days("400", 2016, from_elements=True)
    settings = campaign.Settings(document, "2016-11-11T00:00:00+00:00", 1.0, 1.0, days_from_elements=True)
    tasks = campaign.plan([0, 2], 1, False)
    overrides = campaign.task_overrides(settings, tasks[1])
    assert overrides["sim.epoch_utc"].startswith("2016-11-13T00:00:00")
    campaign.check(settings, tasks)  # days 0 and 2 fly
    campaign.check(settings, campaign.plan([4], 1, False))  # day 4 from 00:00: an orbit ends before the decay
    with pytest.raises(ValueError, match=r"SGP4 error \d at t = 0.0 s \(2016-11-16T00:00:00Z, \+5.000 days"):
        campaign.check(settings, campaign.plan([1, 5], 1, False))  # day 5 starts after it


def test_the_monitor_removes_the_oblateness_of_an_eccentric_orbit_with_each_samples_altitude():
    # The three nodes' code without ROS (runtime/flight.py, what pmv campaign flies): e = 0.01, perigee
    # 700 km, ideal detector, GRS80. The monitor takes u, inclination and altitude from each odometry
    # state; what it leaves is the closed-form model's error (< 0.5′, tests/physics/test_eccentric_orbit.py)
    # and the star tracker's noise (3″ across, 20″ about the boresight).
    from pmv_ros.physics.constants import ARCMIN_RAD, EARTH_MEAN_RADIUS_M, GM_EARTH_M3_S2
    from pmv_ros.physics.attitude import true_roll_pitch
    from pmv_ros.runtime.common.assembly import build_models
    from pmv_ros.runtime.flight import flight_values, fly

    a_m = (EARTH_MEAN_RADIUS_M + 700e3) / 0.99
    mean_motion = math.sqrt(GM_EARTH_M3_S2 / a_m**3) * 86400.0 / (2.0 * math.pi)
    line1, line2 = make_element_set(EPOCH, 98.8, 0.0, 0.01, 45.0, 0.0, mean_motion)
    overrides = {"orbit.tle_line1": line1, "orbit.tle_line2": line2, "sensor.detector": "ideal",
                 "radiance.source": "uniform", "sensor.rate_hz": 0.5, "sensor.bright_body_exclusion_deg": 0.0,
                 "remove_oblateness": True}
    values = flight_values(preset_document(), overrides)
    flight = fly(values, 2950)  # one orbit at 0.5 Hz
    sigma = {c.channel: c.sigma_rad / ARCMIN_RAD for c in flight.summary.channels}
    assert sigma["roll"] < 0.5 and sigma["pitch"] < 0.5
    # the oblateness error the monitor took out: the sensed pitch less the body's true pitch
    _, profile, _ = build_models(values.sensor)
    _, true_pitch = true_roll_pitch(profile.quaternion(flight.t_s))
    assert np.nanstd(flight.sensed_pitch_rad - true_pitch) / ARCMIN_RAD > 3.0
