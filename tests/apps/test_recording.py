"""Recordings (issue 13): ``pmv simulate --record``, ``pmv analyze`` on rosbag2 recordings, the orbit on the wire.

The round trip is the Must-show of the issue: one Kondor orbit at 1 Hz recorded
by ``pmv simulate --record run.mcap``, then ``pmv analyze run.mcap --altitude-km
500 --inclination-deg 74.5``; the MCAP is read back by the other library
(``mcap`` + ``mcap-ros2-support``); a run whose clock starts at a wall-clock
time is analysed without the phase error stamps would give; bad recordings
give one line and exit 2.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import pmv_msgs_shim as shim
from cli_runner import pmv
from pmv_ros.cli import main
from pmv_ros.physics.orbit.two_body import CircularOrbit
from pmv_ros.storage.recording import McapRecording

pytestmark = [pytest.mark.xdist_group("kondor_orbit_run")]

REPO = Path(__file__).resolve().parents[2]
PMV = Path(sys.executable).parent / "pmv"
KONDOR = REPO / "config/kondor.yaml"
ANALYZE_KONDOR = ("--altitude-km", "500", "--inclination-deg", "74.5")

#: Every topic a pmv simulate run has (the recorder takes what the graph lists), with its type.
RUN_TOPICS = {
    "/pmv/horizon_crossings": "geometry_msgs/msg/PolygonStamped",
    "/pmv/attitude": "geometry_msgs/msg/Vector3Stamped",
    "/pmv/attitude_uncorrected": "geometry_msgs/msg/Vector3Stamped",
    "/attitude/truth": "geometry_msgs/msg/QuaternionStamped",
    "/orbit/odometry": "nav_msgs/msg/Odometry",
    "/star_tracker/attitude": "geometry_msgs/msg/QuaternionStamped",
    "/pmv/residual": "geometry_msgs/msg/Vector3Stamped",
    "/pmv/error_statistics": "diagnostic_msgs/msg/DiagnosticArray",
    "/diagnostics": "diagnostic_msgs/msg/DiagnosticArray",
    "/clock": "rosgraph_msgs/msg/Clock",
}

#: The round trip's agreement: the issue's 2 %. The per-sample statistics of the recording go through
#: the monitor's own alignment, so they differ from the live ones only by the samples still waiting
#: for truth when the live statistics were taken (≤ a few of 5,600).
AGREEMENT = 0.02
#: A mean near zero gets an absolute floor instead, arcmin: those few waiting samples (σ ≈ 3′) move a mean
#: over ≈ 5,600 samples by ≈ 3·3′/5600 ≈ 0.002′, which is more than 2 % of a mean of 0.015′ (the flight
#: environment of issue 22 gives Kondor's residual means of that size).
MEAN_FLOOR_ARCMIN = 0.01
#: The same for the flight-test procedure's offsets, which weigh every 1° bin alike: with the star tracker's
#: once-an-orbit exclusion (≈ 15 % of the orbit at one u) the oblateness-free residual's orbital terms no longer
#: average out of the running mean: 0.06′ (roll) and 0.88′ (pitch) measured, 1.2′ allowed.
GAPPY_MEAN_FLOOR_ARCMIN = 1.2

#: Methodical error of Kondor, oblateness excluded: the flight analysis' limit ≈ 8′ (physics.md §5).
METHODICAL_LIMIT_ARCMIN = 8.0


def _analyze(capsys, *argv) -> dict:
    status = main(["analyze", *map(str, argv), *ANALYZE_KONDOR, "--json"])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    return json.loads(captured.out)


@pytest.fixture
def round_trip(kondor_orbit_run):
    """The issue's run: ``pmv simulate … --orbits 1 --rate-hz 1 --record run.mcap`` (conftest's run, with
    ``--report`` too); (path, simulate's JSON)."""
    return kondor_orbit_run.mcap, kondor_orbit_run.summary


@pytest.fixture(scope="module")
def round_trip_report(kondor_orbit_run) -> dict:
    """``pmv analyze run.mcap`` on the shared orbit (in this process), once for the tests that read it."""
    result = pmv("analyze", kondor_orbit_run.mcap, *ANALYZE_KONDOR, "--json")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def test_round_trip_statistics_agree_with_the_live_ones(round_trip, round_trip_report):
    _, live = round_trip
    report = round_trip_report
    assert report["layout"] == "recording" and report["phase_source"] == "/orbit/odometry"
    assert report["truth_topic"] == "/star_tracker/attitude"
    assert report["convention"] == shim.WIRE_CONVENTION  # stated by the sensor on /diagnostics
    for channel in ("roll", "pitch", "meridional"):
        recorded, running = report["per_sample"][channel], live["channels"][channel]
        assert recorded["count"] == pytest.approx(running["count"], rel=0.002)
        assert recorded["sigma_arcmin"] == pytest.approx(running["sigma_arcmin"], rel=AGREEMENT)
        assert recorded["mean_arcmin"] == pytest.approx(running["mean_arcmin"], rel=AGREEMENT, abs=MEAN_FLOOR_ARCMIN)
    # The flight-test procedure on the same residuals: its offsets K, T are the means of the u-binned
    # averages — with the orbit sampled evenly, the running means within the same 2 %.
    # The star tracker's gaps (the Sun near the boresight once an orbit at this epoch, ≈ 15 % of it at one u)
    # leave the orbit unevenly sampled: K and T, means of the bins, part from the running means.
    assert report["roll_offset_arcmin"] == pytest.approx(live["channels"]["roll"]["mean_arcmin"], rel=AGREEMENT,
                                                         abs=GAPPY_MEAN_FLOOR_ARCMIN)
    assert report["pitch_offset_arcmin"] == pytest.approx(live["channels"]["pitch"]["mean_arcmin"], rel=AGREEMENT,
                                                          abs=GAPPY_MEAN_FLOOR_ARCMIN)
    # Its σ is of the 1° bin averages (≈ 16 samples each), which average out what varies within 16 s
    # (≈ 110 km of a horizon point's track): below the per-sample σ, never above it. With the calibrated
    # mesoscale layer height (R_h = 50 km, issue 22) that is a good part of the scatter: measured 0.79.
    for channel in ("roll", "pitch"):
        ratio = report["channels"][channel]["sigma_arcmin"] / live["channels"][channel]["sigma_arcmin"]
        assert 0.6 < ratio <= 1.0, ratio
    # 1° bins over one orbit; the Sun in a chord can blank one angle or the other for tens of seconds of
    # the orbit (≈ 40 s on 15 Jan 2024; none on kondor.yaml's 10 Sep 2013), and the star tracker gives no truth
    # for ≈ 16 % of it (the Sun near its boresight once an orbit at this epoch) and in star-poor fields:
    # 289 of 360 bins measured.
    assert report["orbits"] == 1 and 250 <= report["orbital_angles"] <= 360


def test_the_mcap_opens_with_the_other_library(round_trip):
    """mcap + mcap-ros2-support (the analysis reads with rosbags): topics, types, counts, decodable messages."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    path, live = round_trip
    period = CircularOrbit(500e3, math.radians(74.5)).period_s
    ticks = round(period * 1.0)
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        channels = {c.topic: c for c in summary.channels.values()}
        counts = {topic: summary.statistics.channel_message_counts.get(c.id, 0) for topic, c in channels.items()}
        types = {topic: summary.schemas[c.schema_id].name for topic, c in channels.items()}
        assert all(c.message_encoding == "cdr" for c in channels.values())
        assert all(summary.schemas[c.schema_id].encoding == "ros2msg" for c in channels.values())
        for topic, type_name in RUN_TOPICS.items():
            assert types.get(topic) == type_name, (topic, types.get(topic))
        # What the recorder says it wrote, and what the run published: one sample per tick on each sensor topic.
        assert {t: n for t, n in counts.items() if n} == {t: n for t, n in live["recording"]["messages"].items() if n}
        for topic in ("/pmv/attitude", "/pmv/attitude_uncorrected", "/pmv/horizon_crossings", "/orbit/odometry",
                      "/attitude/truth", "/clock"):
            assert counts[topic] == ticks, (topic, counts[topic])
        # The star tracker a frame a second less the frames without attitude (physics.md §6: the Sun once an orbit
        # at this epoch, star-poor fields, the SAA); statistics at 1 Hz plus the final one.
        assert 0.6 * ticks <= counts["/star_tracker/attitude"] <= ticks
        assert counts["/pmv/residual"] == pytest.approx(ticks, rel=0.3)
        assert counts["/pmv/error_statistics"] == pytest.approx(ticks, abs=2)
        decoded = {}
        for _, channel, message, ros_msg in reader.iter_decoded_messages():
            decoded.setdefault(channel.topic, (message, ros_msg))
            if len(decoded) == len(RUN_TOPICS):
                break
    _, odometry = decoded["/orbit/odometry"]
    assert odometry.header.frame_id == shim.ECI_FRAME
    radius = math.sqrt(sum(getattr(odometry.pose.pose.position, a) ** 2 for a in "xyz"))
    assert radius == pytest.approx(6371e3 + 500e3, rel=1e-9)
    log, attitude = decoded["/pmv/attitude"]
    assert attitude.header.frame_id == shim.SENSOR_FRAME and abs(attitude.vector.x) < math.radians(1)
    # Logged at simulation time: the first sample's stamp.
    assert log.log_time == attitude.header.stamp.sec * 10**9 + attitude.header.stamp.nanosec
    assert len(decoded["/pmv/horizon_crossings"][1].polygon.points) == 4


def test_the_epoch_and_elements_are_on_the_sensors_diagnostics(round_trip):
    from pmv_ros.storage.recording import read_recording

    path, _ = round_trip
    topics = read_recording(path, {"/diagnostics": ("diagnostic_msgs/msg/DiagnosticArray",),
                                   "/orbit/odometry": ("nav_msgs/msg/Odometry",)})
    found = [e for e in (shim.find_orbit_elements(m.message) for m in topics["/diagnostics"]) if e is not None]
    assert found and all(e == found[0] for e in found)
    elements = found[0]
    import yaml

    preset = yaml.safe_load(KONDOR.read_text())["/**"]["ros__parameters"]  # the epoch, shared with the star tracker
    assert elements.epoch_utc == preset["sim"]["epoch_utc"]   # kondor.yaml sim.epoch_utc
    assert (elements.altitude_km, elements.inclination_deg, elements.arg_latitude_deg) == (500.0, 74.5, 0.0)
    assert elements.roll_pitch_convention == shim.WIRE_CONVENTION
    # Anyone can put the spacecraft where the odometry says it was from the elements and a stamp:
    # u of the odometry's position against u from the elements, to 1e-9 rad.
    from pmv_ros.physics.orbit.two_body import orbit_angles_from_state

    for recorded in topics["/orbit/odometry"][::500]:
        stamp_s, position, velocity = shim.read_orbit_state(recorded.message)
        u, _, _ = orbit_angles_from_state(position, velocity)
        expected = elements.argument_of_latitude_rad(stamp_s) % (2 * math.pi)
        assert abs(math.remainder(u - expected, 2 * math.pi)) < 1e-9


@pytest.fixture(scope="module")
def wall_clock_run(tmp_path_factory):
    """Half a Kondor orbit whose clock starts at a wall-clock time, recorded; (path, live statistics, start).

    Half an orbit is enough for what the phase decides: the oblateness model (k = 1 roll, k = 2 pitch)
    removed at the wrong u stays in the residual over any stretch of the orbit. At 0.5 Hz (≈ 1,400 samples,
    ≈ 8 to a 1° bin): the phase error does not depend on the rate, and fewer samples to a bin average less of
    the scatter out, which moves MO towards the per-sample mean, inside the bounds below."""
    from pmv_ros.apps.report import statistics_to_dict
    from pmv_ros.nodes.pipeline import Pipeline

    # What a real-time node does: its orbit starts at u0 when the node starts, at whatever Unix time
    # that is (a day plus an odd fraction of an orbit), so the stamps say nothing of the phase.
    start_s = 1_796_158_000.0 + 1234.5
    path = tmp_path_factory.mktemp("wall_clock") / "wall_clock.mcap"
    rate_hz = 0.5
    with Pipeline(KONDOR, {"sensor.rate_hz": rate_hz, "sim.start_time_s": start_s}, record=path) as pipeline:
        ticks = round(pipeline.sensor.orbit.period_s / 2 * rate_hz)
        pipeline.step(ticks)
        live = statistics_to_dict(pipeline.monitor.publish_statistics(pipeline.sensor.sim_time_s))
        pipeline.drain()
    return path, live, start_s


def test_a_wall_clock_recording_is_analysed_at_the_right_phase(wall_clock_run, capsys, tmp_path):
    path, live, start_s = wall_clock_run
    report = _analyze(capsys, path)
    for channel in ("roll", "pitch"):
        assert report["per_sample"][channel]["mean_arcmin"] == pytest.approx(live["channels"][channel]["mean_arcmin"],
                                                                            rel=AGREEMENT, abs=MEAN_FLOOR_ARCMIN)
        assert report["per_sample"][channel]["sigma_arcmin"] == pytest.approx(
            live["channels"][channel]["sigma_arcmin"], rel=AGREEMENT)
    # The same from the elements on /diagnostics instead of the odometry.
    by_elements = _analyze(capsys, path, "--phase", "elements")
    assert by_elements["phase_source"].startswith("orbit elements")
    assert by_elements["mo_arcmin"] == pytest.approx(report["mo_arcmin"], rel=1e-6)

    # What taking the Unix stamps as the orbital time does (the mistake): the same residuals,
    # the phase from u = 2π t / T with t the stamp.
    rows = ["t_s,roll_rad,pitch_rad,truth_roll_rad,truth_pitch_rad"]
    from pmv_ros.storage.recording import read_recording

    topics = read_recording(path, {"/pmv/residual": ("geometry_msgs/msg/Vector3Stamped",)})
    for recorded in topics["/pmv/residual"]:
        stamp_s, roll, pitch = shim.read_attitude_angles(recorded.message)
        rows.append(f"{stamp_s!r},{roll!r},{pitch!r},0,0")
    stamps_csv = tmp_path / "stamps.csv"
    stamps_csv.write_text("\n".join(rows) + "\n")
    wrong = _analyze(capsys, stamps_csv, "--u0-deg", 0, "--convention", shim.WIRE_CONVENTION)

    # Right phase: the residual is the live monitor's (above, 2 %), the flight-test MO is the per-sample
    # meridional mean it should be, and each channel's mean is small against its methodical scatter.
    # MO is the mean magnitude of 1° bin averages (≈ 8 samples each at 0.5 Hz): the flight environment's mesoscale
    # window-layer scatter (correlated over ≈ 15 s of track, physics.md §3.2 item 4) partly averages out
    # in a bin, so MO runs below the per-sample mean (measured ×0.91 with R_h = 100 km; ×0.79 with the
    # R_h = 50 km of issue 22's calibration), never above it.
    per_sample_mo = report["per_sample"]["meridional"]["mean_arcmin"]
    assert 0.7 * per_sample_mo < report["mo_arcmin"] <= (1.0 + AGREEMENT) * per_sample_mo
    for channel in ("roll", "pitch"):
        assert abs(report["per_sample"][channel]["mean_arcmin"]) < report["per_sample"][channel]["sigma_arcmin"]
    # Stamp phase: the model (≈ 5′ roll, 9′ pitch, physics.md §2.1) removed at the wrong u stays in the
    # residual — the same samples give a much larger MO and pitch σ (measured: MO 16.0′ against 8.0′,
    # pitch σ 14.6′ against 7.4′).
    assert wrong["mo_arcmin"] > 1.5 * report["mo_arcmin"]
    assert wrong["channels"]["pitch"]["sigma_arcmin"] > 1.5 * report["channels"]["pitch"]["sigma_arcmin"]
    print(f"wall-clock run: MO {report['mo_arcmin']:.2f}′ (phase from odometry) vs {wrong['mo_arcmin']:.2f}′ "
          f"(phase from stamps); pitch σ {report['channels']['pitch']['sigma_arcmin']:.2f}′ vs "
          f"{wrong['channels']['pitch']['sigma_arcmin']:.2f}′")


def test_sqlite3_recording_of_another_stack(round_trip, tmp_path, capsys):
    """The same messages in a rosbag2 sqlite3 bag written by rosbags, without the sensor's /diagnostics."""
    from mcap.reader import make_reader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    path, live = round_trip
    typestore = get_typestore(Stores.ROS2_JAZZY)
    bag = tmp_path / "other_stack"
    topics = {"/pmv/attitude": RUN_TOPICS["/pmv/attitude"], "/attitude/truth": RUN_TOPICS["/attitude/truth"],
              "/orbit/odometry": RUN_TOPICS["/orbit/odometry"]}
    with Writer(bag, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer, open(path, "rb") as stream:
        connections = {topic: writer.add_connection(topic, kind, typestore=typestore) for topic, kind in topics.items()}
        for _, channel, message in make_reader(stream).iter_messages(topics=list(topics)):
            writer.write(connections[channel.topic], message.log_time, message.data)
    assert any(bag.glob("*.db3"))
    # No sensor status: the convention is named, and the truth is the attitude model's own topic.
    report = _analyze(capsys, bag, "--convention", shim.WIRE_CONVENTION)
    assert report["truth_topic"] == "/attitude/truth" and report["phase_source"] == "/orbit/odometry"
    assert report["recording"]["orbit_elements"] is None
    # Truth without the star tracker's 3″ noise and latency: the same statistics within the 2 %.
    for channel in ("roll", "pitch"):
        assert report["per_sample"][channel]["sigma_arcmin"] == pytest.approx(
            live["channels"][channel]["sigma_arcmin"], rel=AGREEMENT)
    # The bare storage file opens too.
    file_report = _analyze(capsys, next(bag.glob("*.db3")), "--convention", shim.WIRE_CONVENTION)
    assert file_report["per_sample"] == report["per_sample"]
    # And the convention matters: read as the other one, the oblateness model doubles instead of cancelling.
    other = "ros" if shim.WIRE_CONVENTION == "paper" else "paper"
    flipped = _analyze(capsys, bag, "--convention", other)
    assert flipped["channels"]["pitch"]["harmonics_arcmin"]["2"] > 10.0


def _subset(source: Path, target: Path, topics, replace: dict | None = None, seconds: float | None = None,
            rename=lambda topic: topic) -> Path:
    """A new MCAP with only ``topics`` of ``source`` (raw bytes), and ``replace``: {topic: (type, bytes)}; with
    ``seconds``, only the messages of the first ``seconds`` of the recording; each topic named ``rename(topic)``."""
    from mcap.reader import make_reader

    with McapRecording(target) as recording, open(source, "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        end_ns = None if seconds is None else summary.statistics.message_start_time + int(seconds * 1e9)
        for channel in summary.channels.values():
            if channel.topic in topics:
                recording.add_topic(rename(channel.topic), summary.schemas[channel.schema_id].name)
        for topic, (type_name, _) in (replace or {}).items():
            recording.add_topic(topic, type_name)
        for _, channel, message in reader.iter_messages(topics=list(topics), ending_before=end_ns):
            recording.write(rename(channel.topic), message.log_time, message.data)
        for topic, (_, data) in (replace or {}).items():
            recording.write(topic, 1, data)
    return target


def _topics(path: Path) -> set:
    """Every topic of an MCAP file."""
    from mcap.reader import make_reader

    with open(path, "rb") as stream:
        return {channel.topic for channel in make_reader(stream).get_summary().channels.values()}


#: The stretch of the shared orbit that the namespace and bad-recording tests copy, s: what they check (the same
#: statistics under another name, a refusal naming a topic) does not depend on the length; a quarter orbit
#: (≈ 1,400 samples, the orbit status on /diagnostics among them) reads in a quarter of the time.
STRETCH_S = 1400.0


def test_a_namespaced_recording_is_read_with_its_namespace(round_trip, tmp_path, capsys):
    """A spacecraft under /sat1 (its topics /sat1/pmv/attitude, …; /diagnostics shared): --namespace sat1 reads
    the same statistics as the un-namespaced recording of the same messages; without it, a one-line error."""
    path, _ = round_trip
    # Every topic of the run, the same stretch of it twice: as recorded, and moved under /sat1.
    plain_path = _subset(path, tmp_path / "plain.mcap", _topics(path), seconds=STRETCH_S)
    moved = _subset(path, tmp_path / "sat1.mcap", _topics(path), seconds=STRETCH_S,
                    rename=lambda topic: topic if topic.startswith("/diagnostics") else "/sat1" + topic)
    plain = _analyze(capsys, plain_path)
    report = _analyze(capsys, moved, "--namespace", "sat1")
    assert plain["per_sample"]["roll"]["count"] > 1000  # the stretch holds a real share of the orbit
    assert report["truth_topic"] == "/sat1/star_tracker/attitude" and report["phase_source"] == "/sat1/orbit/odometry"
    assert report["per_sample"] == plain["per_sample"] and report["channels"] == plain["channels"]
    # The orbit status on /diagnostics is the un-namespaced sensor's here: not taken for sat1's.
    assert plain["recording"]["orbit_elements"] is not None and report["recording"]["orbit_elements"] is None
    assert "/pmv/attitude" in _one_line_error(capsys, moved)
    assert shim.orbit_status_name("/sat1") == "pmv_ros/sat1/sensor_node: orbit"
    assert shim.orbit_status_name("") == shim.ORBIT_STATUS_NAME
    with pytest.raises(SystemExit) as refused:  # argparse refuses it
        main(["analyze", str(moved), *ANALYZE_KONDOR, "--namespace", "sat 1"])
    assert refused.value.code == 2
    assert "not a ROS namespace" in capsys.readouterr().err


def _one_line_error(capsys, path, *extra) -> str:
    status = main(["analyze", str(path), *ANALYZE_KONDOR, *extra])
    captured = capsys.readouterr()
    assert status == 2, captured
    assert captured.out == "" and "Traceback" not in captured.err
    assert captured.err.count("\n") == 1, captured.err
    assert str(path) in captured.err
    return captured.err


def test_bad_recordings_give_one_line_errors(round_trip, tmp_path, capsys):
    from rclpy.serialization import serialize_message
    from std_msgs.msg import String

    full, _ = round_trip
    path = _subset(full, tmp_path / "stretch.mcap", _topics(full), seconds=STRETCH_S)  # read whole: namespace test
    everything = set(RUN_TOPICS)
    no_sensor = _subset(path, tmp_path / "no_sensor.mcap", everything - {"/pmv/attitude"})
    assert "no topic /pmv/attitude" in _one_line_error(capsys, no_sensor)
    no_truth = _subset(path, tmp_path / "no_truth.mcap", {"/pmv/attitude", "/orbit/odometry"})
    error = _one_line_error(capsys, no_truth)
    assert "no truth" in error and "/star_tracker/attitude" in error and "--truth" in error
    assert "/my/truth" in _one_line_error(capsys, no_truth, "--truth", "/my/truth")
    no_phase = _subset(path, tmp_path / "no_phase.mcap", {"/pmv/attitude", "/star_tracker/attitude"})
    error = _one_line_error(capsys, no_phase)
    assert "orbital phase" in error and "/orbit/odometry" in error
    wrong_type = _subset(path, tmp_path / "wrong_type.mcap", {"/star_tracker/attitude", "/orbit/odometry"},
                         {"/pmv/attitude": ("std_msgs/msg/String", serialize_message(String(data="roll")))})
    error = _one_line_error(capsys, wrong_type)
    assert "/pmv/attitude is std_msgs/msg/String" in error and "geometry_msgs/msg/Vector3Stamped" in error
    truncated = tmp_path / "truncated.mcap"
    data = path.read_bytes()
    truncated.write_bytes(data[:40])  # the header only: a cut file with nothing in it (tests/system: longer cuts)
    assert "no topic /pmv/attitude" in _one_line_error(capsys, truncated)
    garbage = tmp_path / "garbage.mcap"
    garbage.write_bytes(b"not a recording\n" * 10)
    assert "cannot read the recording" in _one_line_error(capsys, garbage)
    assert "no such file" in _one_line_error(capsys, tmp_path / "missing.mcap")


def test_record_refuses_an_existing_file(tmp_path, capsys):
    target = tmp_path / "run.mcap"
    target.write_bytes(b"keep me")
    status = main(["simulate", "--config", str(KONDOR), "--orbits", "0.001", "--record", str(target), "--quiet"])
    captured = capsys.readouterr()
    assert status == 2 and "exists already" in captured.err and captured.err.count("\n") == 1
    assert target.read_bytes() == b"keep me"


def _odometry(stamp_s, position, twist, q=(0.0, 0.0, 0.0, 1.0), child="pmv_body"):
    stamp = SimpleNamespace(sec=int(stamp_s), nanosec=int(round((stamp_s % 1) * 1e9)))
    message = SimpleNamespace(
        header=SimpleNamespace(stamp=stamp, frame_id="eci"), child_frame_id=child,
        pose=SimpleNamespace(pose=SimpleNamespace(position=SimpleNamespace(x=position[0], y=position[1], z=position[2]),
                                                  orientation=SimpleNamespace(x=q[0], y=q[1], z=q[2], w=q[3]))),
        twist=SimpleNamespace(twist=SimpleNamespace(linear=SimpleNamespace(x=twist[0], y=twist[1], z=twist[2]))))
    return SimpleNamespace(log_time_ns=int(stamp_s * 1e9), message=message)


def test_phase_from_odometry_does_not_depend_on_the_twist_frame():
    """u from the pose positions whatever frame the twist is in; a lone message by nav_msgs' twist semantics."""
    from scipy.spatial.transform import Rotation

    from pmv_ros.apps.telemetry import phase_from_odometry

    orbit = CircularOrbit(500e3, math.radians(74.5), raan_rad=0.7, arg_latitude_at_epoch_rad=1.1, epoch_s=100.0)
    times = 100.0 + np.arange(0.0, 600.0, 10.0)
    positions, velocities = orbit.state_eci(times)
    frames = orbit.orbital_frame_eci(times)
    expected = orbit.argument_of_latitude(times)
    # ECI twist with identity orientation (today), or the twist in the orbital frame with the orbital
    # frame's orientation (child frame 'orbital'), or garbage twist: the positions decide.
    for twist_of in (lambda i: velocities[:, i], lambda i: frames[:, :, i].T @ velocities[:, i],
                     lambda i: np.array([1.0, -2.0, 3.0])):
        messages = [_odometry(t, positions[:, i], twist_of(i)) for i, t in enumerate(times)]
        phase, inclination, altitude, unreadable = phase_from_odometry(messages, 5.0)
        # Between messages u is interpolated linearly: exact for a circular orbit's uniform u.
        difference = phase(times + 3.0) - orbit.argument_of_latitude(times + 3.0)
        assert np.abs(np.remainder(difference + math.pi, 2 * math.pi) - math.pi).max() < 1e-9
        assert inclination == pytest.approx(74.5, abs=1e-6) and altitude == pytest.approx(500.0, abs=1e-6)
        assert unreadable == 0
        assert math.isnan(phase(times[-1] + 60.0))  # beyond the 5 s odometry timeout: unknown
    # One message: the twist in the child frame, rotated by the pose orientation (nav_msgs).
    i = 7
    q = Rotation.from_matrix(frames[:, :, i]).as_quat()
    lone = [_odometry(times[i], positions[:, i], frames[:, :, i].T @ velocities[:, i], q=q, child="orbital")]
    phase, inclination, _, _ = phase_from_odometry(lone, 5.0)
    assert math.remainder(float(phase(times[i])) - expected[i], 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    assert inclination == pytest.approx(74.5, abs=1e-9)


def test_orbit_status_round_trip_and_a_real_time_sensors_epoch(harness):
    """The orbit status survives the wire; a real-time sensor's epoch stamp is its start on the wall clock."""
    import time

    from diagnostic_msgs.msg import DiagnosticArray

    from pmv_ros.nodes.sensor_node import SensorNode

    elements = shim.OrbitElements("2019-07-21T00:00:00Z", 1.7e9, 835.0, 98.8, 10.0, 45.0, 6090.0, 0.98, "ros")
    message = shim.write_health(DiagnosticArray(),
                                shim.HealthReport(1.7e9, (shim.orbit_elements_status(elements),)))
    assert shim.find_orbit_elements(message) == elements
    assert elements.argument_of_latitude_rad(1.7e9 + 6090.0 / 4) == pytest.approx(math.radians(45.0 + 90.0))
    message.status[0].values = [kv for kv in message.status[0].values if kv.key != "period_s"]
    with pytest.raises(ValueError, match="period_s"):
        shim.find_orbit_elements(message)

    before = time.time()
    h = harness(SensorNode, {"sim.fast_time": False, "sensor.rate_hz": 1.0, "sensor.detector": "ideal",
                             "orbit.u0_deg": 30.0, "sim.epoch_utc": "2026-12-01T12:00:00Z"})
    diagnostics = h.record(DiagnosticArray, "/diagnostics")
    h.node.tick()  # the 1 Hz timer's work, without waiting for it
    h.drain()
    found = [e for e in (shim.find_orbit_elements(m) for m in diagnostics) if e is not None]
    assert found, "no orbit status on the sensor's /diagnostics"
    assert before - 1.0 <= found[0].epoch_stamp_s <= time.time()
    assert found[0].epoch_utc == "2026-12-01T12:00:00Z" and found[0].arg_latitude_deg == pytest.approx(30.0)
