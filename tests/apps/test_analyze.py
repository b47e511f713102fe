"""``pmv analyze``: the flight-test procedure (physics.md §5) on telemetry built from published numbers."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from pmv_ros.physics.published import KONDOR_ALTITUDE_KM, KONDOR_INCLINATION_DEG, KONDOR_OBLATENESS_TABLE

from pmv_ros.cli import main
from pmv_ros.physics.conventions import convert

KONDOR_TABLE = KONDOR_OBLATENESS_TABLE  # physics.md §2.1, Kondor, a quarter orbit

# Our closed form deviates from the printed table by ≤ 0.2′ per component (the
# table is printed to 0.1′, and its R/ellipsoid roundings are not published), so
# each residual component is ≤ 0.2′ + 0.05′ of print rounding, the meridional
# residual ≤ √2 · 0.25′ ≈ 0.35′: that bounds MO and max |δβ_m|, and σ_m of values
# in [0, 0.35′] is at most half that range, 0.18′ (so MO + 3σ_m < 0.9′). The offsets come
# back to float precision because the symmetric extension of the table averages
# to exactly zero over an orbit; 0.01′ leaves room for the arithmetic only.
RESIDUAL_TOLERANCE_ARCMIN = 0.35
SIGMA_TOLERANCE_ARCMIN = 0.18
OFFSET_TOLERANCE_ARCMIN = 0.01


def kondor_full_orbit(step_deg: int = 15):
    """The table extended over a whole orbit by the symmetry of the closed form.

    Pitch varies at twice the orbital frequency and roll at the orbital
    frequency (physics.md §2.1): pitch(180° − u) = −pitch(u), roll(180° − u) =
    roll(u); pitch(u + 180°) = pitch(u), roll(u + 180°) = −roll(u).
    """
    quarter = {row[0]: (row[3], row[2]) for row in KONDOR_TABLE}   # u -> (roll, pitch)
    rows = []
    for u in range(0, 360, step_deg):
        half = u % 180
        roll, pitch = quarter[half] if half <= 90 else quarter[180 - half]
        if half > 90:
            pitch = -pitch
        if u >= 180:
            roll = -roll
        rows.append((u, roll, pitch))
    return rows


def write_orbit_csv(path, rows_by_orbit):
    lines = ["orbit,u_deg,roll_arcmin,pitch_arcmin"]
    for orbit, rows in rows_by_orbit:
        lines += [f"{orbit},{u},{roll:.4f},{pitch:.4f}" for u, roll, pitch in rows]
    path.write_text("\n".join(lines) + "\n")


def run_json(capsys, *argv):
    status = main(["analyze", *map(str, argv), "--altitude-km", str(KONDOR_ALTITUDE_KM),
                   "--inclination-deg", str(KONDOR_INCLINATION_DEG), "--json"])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    return json.loads(captured.out)


def test_symmetric_extension_matches_the_table_where_it_overlaps():
    rows = {u: (roll, pitch) for u, roll, pitch in kondor_full_orbit()}
    for u, _, pitch, roll in KONDOR_TABLE:
        assert rows[u] == (roll, pitch)
    # Second quarter: the pitch sign flips, the roll keeps its sign (the roll peak is at u = 90°).
    assert rows[105] == (-4.7, -4.5) and rows[195] == (1.3, 4.6)


def test_kondor_table_plus_offset_returns_the_offset_and_a_near_zero_residual(tmp_path, capsys):
    roll_offset, pitch_offset = 2.5, -3.75    # arcmin: a mounting error and an orbital pitch bias
    orbit_rows = kondor_full_orbit()
    # Four orbits, as in the published Kondor analysis, with orbit-to-orbit scatter of 0.5′ that
    # averages to exactly zero at each u — step 2 (averaging over the orbits) must remove it.
    scatter = np.random.default_rng(7).normal(0.0, 0.5, size=(4, len(orbit_rows), 2))
    scatter[3] = -scatter[:3].sum(axis=0)
    csv_rows = [(orbit + 1, [(u, roll + roll_offset + s[0], pitch + pitch_offset + s[1])
                             for (u, roll, pitch), s in zip(orbit_rows, scatter[orbit])])
                for orbit in range(4)]
    path = tmp_path / "kondor.csv"
    write_orbit_csv(path, csv_rows)

    report = run_json(capsys, path)
    assert report["layout"] == "orbit" and report["orbits"] == 4 and report["orbital_angles"] == 24
    assert report["roll_offset_arcmin"] == pytest.approx(roll_offset, abs=OFFSET_TOLERANCE_ARCMIN)
    assert report["pitch_offset_arcmin"] == pytest.approx(pitch_offset, abs=OFFSET_TOLERANCE_ARCMIN)
    assert report["channels"]["roll"]["offset_arcmin"] == pytest.approx(roll_offset, abs=OFFSET_TOLERANCE_ARCMIN)
    assert 0.0 <= report["mo_arcmin"] < RESIDUAL_TOLERANCE_ARCMIN
    assert report["channels"]["meridional"]["max_abs_arcmin"] < RESIDUAL_TOLERANCE_ARCMIN
    assert report["sigma_arcmin"] < SIGMA_TOLERANCE_ARCMIN
    assert report["limit_arcmin"] == pytest.approx(report["mo_arcmin"] + 3 * report["sigma_arcmin"])
    assert report["limit_low_arcmin"] == pytest.approx(report["mo_arcmin"] - 3 * report["sigma_arcmin"])
    for row in report["series"]:
        assert abs(row["residual_roll_arcmin"]) < 0.25 and abs(row["residual_pitch_arcmin"]) < 0.25
    # Per-orbit harmonics see the scatter (it only cancels in the average over orbits), so they are
    # checked on clean data below; here only that all four orbits were used.
    assert report["channels"]["roll"]["orbits_in_harmonics"] == 4


def test_harmonics_show_the_oblateness_and_its_removal(tmp_path, capsys):
    path = tmp_path / "kondor.csv"
    write_orbit_csv(path, [(1, kondor_full_orbit()), (2, kondor_full_orbit())])
    report = run_json(capsys, path)
    roll, pitch = report["channels"]["roll"], report["channels"]["pitch"]
    # §5.1: before the removal the oblateness is roll at k = 1 (the table's −4.9′ at u = 90°) and pitch at
    # k = 2 (9.1′ at u = 45°), each within 0.3′ (other harmonics of the not-quite-sinusoidal shape);
    # after it those amplitudes are at the table-vs-model level (≤ 0.25′ per sample, see above).
    assert roll["harmonics_with_oblateness_arcmin"]["1"] == pytest.approx(4.9, abs=0.3)
    assert pitch["harmonics_with_oblateness_arcmin"]["2"] == pytest.approx(9.1, abs=0.3)
    assert roll["harmonics_with_oblateness_arcmin"]["2"] < 0.05
    assert pitch["harmonics_with_oblateness_arcmin"]["1"] < 0.05
    assert roll["harmonics_arcmin"]["1"] < 0.3 and pitch["harmonics_arcmin"]["2"] < 0.3
    # k ≥ 15 is beyond the Nyquist limit of 24 samples an orbit: unresolved, reported as null.
    assert roll["harmonics_arcmin"]["20"] is None
    assert roll["orbits_in_harmonics"] == 2


def test_without_oblateness_removal_the_residual_is_the_oblateness(tmp_path, capsys):
    path = tmp_path / "kondor.csv"
    write_orbit_csv(path, [(1, kondor_full_orbit())])
    report = run_json(capsys, path, "--keep-oblateness")
    assert report["oblateness_removed"] is False
    # The meridional residual is then the published meridional component, |9.7′| at its peak.
    assert report["channels"]["meridional"]["max_abs_arcmin"] == pytest.approx(9.7, abs=0.1)


def test_a_wrong_roll_sign_convention_would_show(tmp_path, capsys):
    # Telemetry with the roll sign of the text (+ sin B) instead of the table's: a residual of 2×roll.
    flipped = [(u, -roll, pitch) for u, roll, pitch in kondor_full_orbit()]
    path = tmp_path / "flipped.csv"
    write_orbit_csv(path, [(1, flipped)])
    report = run_json(capsys, path)
    assert report["channels"]["roll"]["max_abs_arcmin"] > 9.0


def test_time_layout_with_truth_and_drift(tmp_path, capsys):
    from pmv_ros.physics.constants import ARCMIN_RAD
    from pmv_ros.physics.instrument.oblateness import closed_form_oblateness
    from pmv_ros.physics.orbit.two_body import CircularOrbit

    inclination = math.radians(KONDOR_INCLINATION_DEG)
    period = CircularOrbit(KONDOR_ALTITUDE_KM * 1e3, inclination).period_s
    t = np.arange(0.0, 3.0 * period, 4.0)
    u0 = math.radians(30.0)
    u = u0 + 2.0 * math.pi * t / period
    # Published-style telemetry is in the paper convention; the core's model speaks REP-103.
    model_roll, model_pitch = convert(*closed_form_oblateness(u, KONDOR_ALTITUDE_KM * 1e3, inclination)[1:],
                                      "ros", "paper")
    truth_roll = 1e-3 * np.sin(t / 300.0)
    truth_pitch = np.full_like(t, -2e-4)
    drift_arcmin_per_orbit = 1.5      # the roll reference drifts by 1.5′ an orbit, reset at each ascending node
    drift = drift_arcmin_per_orbit * ARCMIN_RAD * np.mod(u, 2 * math.pi) / (2 * math.pi)
    ripple = 0.4 * ARCMIN_RAD * np.cos(20.0 * u)          # a k = 20 radiance-zone term of 0.4′
    sensor_roll = truth_roll + model_roll + 1.0 * ARCMIN_RAD + ripple + drift
    sensor_pitch = truth_pitch + model_pitch - 0.5 * ARCMIN_RAD
    path = tmp_path / "run.csv"
    with path.open("w") as stream:
        stream.write("t_s,roll_rad,pitch_rad,truth_roll_rad,truth_pitch_rad\n")
        for row in zip(t, sensor_roll, sensor_pitch, truth_roll, truth_pitch):
            stream.write(",".join(repr(float(v)) for v in row) + "\n")
        stream.write("99999,nan,0,0,0\n")   # a telemetry drop-out row: skipped and counted
    report = run_json(capsys, path, "--u0-deg", 30, "--roll-drift-arcmin-per-orbit", drift_arcmin_per_orbit)
    assert report["layout"] == "time" and report["rows_skipped"] == 1
    assert report["roll_offset_arcmin"] == pytest.approx(1.0, abs=0.01)
    assert report["pitch_offset_arcmin"] == pytest.approx(-0.5, abs=0.01)
    roll = report["channels"]["roll"]
    # The per-orbit harmonics (no binning) find the k = 20 ripple. Orbit 0 starts at u0 = 30°: its 30° hole
    # is within the 10 % allowed, so it counts as complete with orbits 1 and 2; the last 30° do not.
    assert roll["harmonics_arcmin"]["20"] == pytest.approx(0.4, abs=0.005)
    assert roll["harmonics_arcmin"]["1"] < 0.01
    assert roll["orbits_in_harmonics"] == 3
    # Step 2 averages in 1° bins, which attenuate k = 20 by sinc(10°) ≈ 0.995: σ of the ripple ≈ 0.4′/√2.
    assert roll["sigma_arcmin"] == pytest.approx(0.4 / math.sqrt(2) * 0.995, rel=0.02)


@pytest.mark.parametrize("content, expected", [
    ("orbit,u_deg,roll_arcmin\n1,0,0\n", "line 1: missing column 'pitch_arcmin'"),
    ("orbit,u_deg,roll_arcmin,pitch_arcmin\n1,0,0,0\n1,15,abc,0\n",
     "line 3, column 'roll_arcmin': 'abc' is not a number"),
    ("orbit,u_deg,roll_arcmin,pitch_arcmin\n1,0,0,0\n1,15,0\n", "line 3: 3 cells, the header has 4"),
    ("t_s,roll_rad,pitch_rad,truth_roll_rad\n1,0,0,0\n", "missing column 'truth_pitch_rad'"),
    ("", "empty file"),
    ("orbit,u_deg,roll_arcmin,pitch_arcmin\n", "no usable data rows"),
    ("orbit,u_deg,roll_arcmin,pitch_arcmin\n1,0,1,1\n", "2 or more distinct orbital angles"),
])
def test_bad_files_give_one_line_errors(tmp_path, capsys, content, expected):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    status = main(["analyze", str(path), "--altitude-km", "500", "--inclination-deg", "74.5"])
    captured = capsys.readouterr()
    assert status == 2
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and "Traceback" not in captured.err
    assert str(path) in captured.err and expected in captured.err


def test_missing_file_is_a_one_line_error(tmp_path, capsys):
    status = main(["analyze", str(tmp_path / "nope.csv"), "--altitude-km", "500", "--inclination-deg", "74.5"])
    captured = capsys.readouterr()
    assert status == 2 and "nope.csv" in captured.err and captured.err.count("\n") == 1


def test_table_output_for_people(tmp_path, capsys):
    path = tmp_path / "kondor.csv"
    write_orbit_csv(path, [(1, kondor_full_orbit())])
    assert main(["analyze", str(path), "--altitude-km", "500", "--inclination-deg", "74.5"]) == 0
    out = capsys.readouterr().out
    assert "MO =" in out and "meridional" in out and "K (roll)" in out


def test_time_layout_without_phase_is_refused(tmp_path, capsys):
    """Stamps alone do not say where the orbit was (issue 13): t_s with neither u_deg nor --u0-deg is refused."""
    path = tmp_path / "stamps.csv"
    path.write_text("t_s,roll_rad,pitch_rad\n1796158000.0,0.001,0.0\n1796158001.0,0.001,0.0\n")
    status = main(["analyze", str(path), "--altitude-km", "500", "--inclination-deg", "74.5"])
    captured = capsys.readouterr()
    assert status == 2 and captured.out == "" and captured.err.count("\n") == 1
    assert str(path) in captured.err and "orbital phase" in captured.err
    assert "'u_deg'" in captured.err and "--u0-deg" in captured.err


def test_time_layout_with_a_phase_column(tmp_path, capsys):
    """A u_deg column gives the phase of each row whatever t_s holds (Unix stamps here)."""
    from pmv_ros.physics.constants import ARCMIN_RAD
    from pmv_ros.physics.instrument.oblateness import closed_form_oblateness

    u = np.radians(np.arange(0.0, 360.0, 2.0))
    model_roll, model_pitch = convert(*closed_form_oblateness(u, KONDOR_ALTITUDE_KM * 1e3,
                                                              math.radians(KONDOR_INCLINATION_DEG))[1:], "ros", "paper")
    t = 1_796_158_000.0 + 4.0 * np.arange(u.size)
    path = tmp_path / "phase.csv"
    lines = ["t_s,roll_rad,pitch_rad,u_deg"]
    lines += [f"{float(ti)!r},{float(r) + 1.0 * ARCMIN_RAD!r},{float(p)!r},{math.degrees(ui)!r}"
              for ti, r, p, ui in zip(t, model_roll, model_pitch, u)]
    path.write_text("\n".join(lines) + "\n")
    report = run_json(capsys, path)
    assert report["phase_source"] == "u_deg column" and report["convention"] == "paper"
    assert report["roll_offset_arcmin"] == pytest.approx(1.0, abs=1e-6)
    assert report["mo_arcmin"] < 1e-6  # the model at the right u removes the oblateness exactly
    # The same numbers told they are in the ROS convention: signs flip, so the model is added, not removed.
    ros = run_json(capsys, path, "--convention", "ros")
    assert ros["convention"] == "ros" and ros["roll_offset_arcmin"] == pytest.approx(1.0, abs=1e-6)
    assert ros["channels"]["pitch"]["max_abs_arcmin"] > 15.0
