"""``pmv campaign``: the core flight equals the pipeline, the batch monitor equals the live one, the CLI's edges.

The Dask runs (embedded against an external scheduler, a worker killed
mid-campaign) are in ``tests/system/test_campaign_dask.py``.
"""

from __future__ import annotations

import math

import numpy as np
from pathlib import Path

import pytest
import yaml
from campaign_cli import campaign_child

from pmv_ros.apps import campaign
from pmv_ros.cli import main
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.star_tracker import Outcome
from pmv_ros.runtime.common.assembly import build_models
from pmv_ros.runtime.monitor.runtime import build_monitor
from pmv_ros.runtime.flight import (OUTCOME_CODES, PENDING_CODE, flight_values, fly, sense_block, wire_clock,
                                   wire_stamps)

pytestmark = [pytest.mark.multi_process]

REPO = Path(__file__).resolve().parents[2]
METEOR = REPO / "config" / "meteor_m2.yaml"


def _document():
    return yaml.safe_load(METEOR.read_text())


def test_campaign_task_equals_the_pipeline_for_the_same_epoch_and_seed(tmp_path):
    """A (day, seed) of the campaign gives the statistics of the in-process pipeline (what `pmv simulate` runs).

    The pipeline is driven directly with the campaign task's overrides (seed
    and sim.epoch_utc for every node), ≈ 150 s of flight at 10 Hz. The two
    share the star tracker's draws, so they agree to the pipeline's message
    stamps, which are whole nanoseconds: 1e-6 arcmin is a thousand times that
    effect (≈ 1e-9′) and a thousand times smaller than one star-tracker draw (3″ = 0.05′).
    """
    from pmv_ros.nodes.pipeline import Pipeline

    settings = campaign.Settings(_document(), "2024-01-15T00:00:00Z", 10.0, 0.025)
    task = campaign.Task(day=182, seed=3)
    table, _ = campaign.run_task(settings, task)
    path = campaign.write_result(tmp_path, task, table)
    _, description = campaign.read_result(path)
    overrides = campaign.task_overrides(settings, task)
    assert overrides["sim.epoch_utc"] == "2024-06-30T00:00:00Z" and overrides["seed"] == 3
    with Pipeline(METEOR, overrides) as pipeline:
        pipeline.step(description["samples"])
        live = pipeline.monitor.monitor.summary()
        lost = {k: v for k, v in pipeline.monitor.truth_lost.items() if v}
    flown = description["summary"]
    # The samples without truth by the tracker's reason: from /star_tracker/frame_status in the graph, from the
    # tracker's frames in the flight.
    assert lost == description["truth_lost"] and sum(lost.values()) > 100, lost
    assert live.counters["used"] > 800  # the star tracker has no attitude for a star-poor minute of this stretch
    assert {k: v for k, v in live.counters.items() if v} == flown["counters"]
    for channel in live.channels:
        mine = flown["channels"][channel.channel]
        assert mine["count"] == channel.count
        for key, value in (("mean_arcmin", channel.mean_rad), ("sigma_arcmin", channel.sigma_rad),
                           ("max_abs_arcmin", channel.max_abs_rad)):
            assert mine[key] == pytest.approx(value / ARCMIN_RAD, abs=1e-6), (channel.channel, key)
        assert channel.sigma_rad / ARCMIN_RAD > 0.5  # the environment is on: a real error, not zeros


def _per_sample_monitor(values, flight):
    """Feed the live ErrorMonitor sample by sample as the pipeline's ticks do; outcomes by stamp and summary."""
    orbit, _, _ = build_models(values.sensor)
    roll, pitch = flight.sensed_roll_rad, flight.sensed_pitch_rad
    monitor = build_monitor(values.monitor)
    frames = flight.frames
    released = {}
    for frame_s, q_measured, released_at, outcome in zip(frames.frame_s, frames.q_measured.T, frames.released_at,
                                                         frames.outcome):
        if outcome == Outcome.OK and released_at >= 0:
            released.setdefault(int(released_at), []).append((float(wire_stamps(frame_s)), q_measured.tolist()))
    position, velocity = orbit.state_eci(flight.t_s)
    outcomes = {}
    # The stamps and the node clock as the monitor reads them off the wire.
    for k, (t, now) in enumerate(zip(wire_stamps(flight.t_s).tolist(), wire_clock(flight.t_s).tolist())):
        for frame_s, q_measured in released.get(k, []):
            outcomes.update((o.stamp_s, o) for o in monitor.add_truth_quaternion(frame_s, q_measured, now_s=now))
        # As error_monitor_node: /orbit/odometry at the sample's stamp, the model from it.
        monitor.add_odometry(t, position[:, k], velocity[:, k], now_s=now)
        orbit_now = monitor.orbit_at(t, values.monitor["odometry_timeout_s"])
        settled = monitor.add_sensor(t, float(roll[k]), float(pitch[k]), now_s=now, **orbit_now)
        outcomes.update((o.stamp_s, o) for o in settled)
    return outcomes, monitor.summary()


@pytest.mark.parametrize("overrides", [
    {},
    # Frequent star-tracker failures, a short gap limit and an outage longer than the wait:
    # every way a sample can be skipped, and one-angle samples (the Sun in a chord).
    {"recognition.failure_at_3": 0.9, "recognition.failure_scale_stars": 3.0, "frame_period_s": 0.5,
     "exposure_s": 0.5, "max_truth_gap_s": 0.9, "outage_start_s": [40.0],
     "outage_duration_s": [15.0], "sensor.bright_body_exclusion_deg": 30.0},
], ids=["clean", "gaps-and-outage"])
def test_batch_monitor_equals_the_live_monitor_sample_by_sample(overrides):
    """runtime/flight's array alignment and statistics against ErrorMonitor fed per sample (its regression guard).

    1e-9 arcmin: the two sum the same residuals in another order (Welford per
    sample against a batch merge).
    """
    values = flight_values(_document(), {"sensor.rate_hz": 10.0, **overrides})
    flight = fly(values, 1500)
    outcomes, live = _per_sample_monitor(values, flight)
    codes = {status: index for index, status in enumerate(OUTCOME_CODES)}
    for k, t in enumerate(wire_stamps(flight.t_s).tolist()):
        outcome = outcomes.get(t)
        expected = PENDING_CODE if outcome is None else codes[outcome.status]
        assert flight.outcome[k] == expected, (k, t)
        if outcome is not None and outcome.ok:
            assert flight.roll_rad[k] == pytest.approx(outcome.roll_rad, abs=1e-12, nan_ok=True)
            assert flight.meridional_rad[k] == pytest.approx(outcome.meridional_rad, abs=1e-12, nan_ok=True)
    assert {k: v for k, v in live.counters.items() if v} == {k: v for k, v in flight.summary.counters.items() if v}
    if overrides:
        skipped = {k for k, v in live.counters.items() if v and k.startswith("skipped_")}
        assert {"skipped_truth_gap", "skipped_stale_truth", "skipped_no_truth"} <= skipped
    for a, b in zip(live.channels, flight.summary.channels):
        assert a.count == b.count
        for name in ("mean_rad", "sigma_rad", "max_abs_rad"):
            assert getattr(b, name) == pytest.approx(getattr(a, name), abs=1e-9 * ARCMIN_RAD), (a.channel, name)


def test_days_lists_and_ranges():
    assert campaign.parse_days("1,91,182,274", 2023) == [1, 91, 182, 274]
    assert campaign.parse_days("1-365:30", 2024) == list(range(1, 366, 30))
    assert campaign.parse_days("300-302, 1", 2024) == [1, 300, 301, 302]
    assert campaign.parse_days("366", 2024) == [366]
    for bad in ("0", "400", "366", "5-1", "1-10:0", "x", "1,,2"):
        with pytest.raises(ValueError):
            campaign.parse_days(bad, 2023)
    assert campaign.day_epoch("2024-01-15T06:30:00Z", 60) == "2024-02-29T06:30:00Z"
    assert [campaign.season_of(campaign.day_epoch("2023-01-15T00:00:00Z", d)) for d in (1, 91, 182, 274)] == \
        ["DJF", "MAM", "JJA", "SON"]


def _campaign_args(out, *extra):
    return ["campaign", "--config", str(METEOR), "--days", "1", "--seeds", "1", "--orbits-per-task", "0.01",
            "--workers", "1", "--out", str(out), *extra]


@pytest.mark.parametrize("arguments, needle", [
    (["--days", "0"], "day 0 is outside"),
    (["--days", "400"], "day 400 is outside"),
    (["--seeds", "0"], "--seeds"),
    (["--orbits-per-task", "0"], "--orbits-per-task"),
    (["--rate-hz", "0.1"], "max_truth_gap_s"),
])
def test_bad_arguments_give_one_line_and_exit_2(tmp_path, capsys, arguments, needle):
    base = _campaign_args(tmp_path / "out")
    for flag, value in zip(arguments[::2], arguments[1::2]):
        if flag in base:
            base[base.index(flag) + 1] = value
        else:
            base += [flag, value]
    try:
        status = main(base)
    except SystemExit as exit_:
        status = exit_.code
    err = capsys.readouterr().err
    assert status == 2
    assert needle in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists() or not list((tmp_path / "out").glob("*.parquet"))


def test_unreachable_scheduler_names_the_address_without_a_traceback(tmp_path):
    import socket

    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    arguments = _campaign_args(tmp_path / "out")[1:]
    arguments[arguments.index("--workers"):arguments.index("--workers") + 2] = ["--scheduler", address]
    # Dask retries a refused connection until the timeout: 2 s here instead of the command's 10 s (the
    # same code path, the wait shorter; tests/apps/test_campaign_trust.py times the silent peer).
    result = campaign_child(arguments, scheduler_timeout_s=2.0)
    assert result.returncode == 2
    assert address in result.stderr and "Traceback" not in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert result.stderr.startswith("pmv campaign: error: cannot reach the Dask scheduler at "), result.stderr


def test_a_folder_keeps_one_campaign_setting(tmp_path, capsys):
    settings = campaign.Settings(_document(), "2024-01-15T00:00:00Z", 10.0, 0.01)
    campaign.prepare_folder(tmp_path, settings)
    campaign.prepare_folder(tmp_path, settings)  # the same settings again: fine
    with pytest.raises(ValueError, match="other settings"):
        campaign.prepare_folder(tmp_path, campaign.Settings(_document(), "2024-01-15T00:00:00Z", 5.0, 0.01))


def test_components_budget_puts_each_component_beside_the_total_and_their_rss(tmp_path):
    """--components: every environment component alone, and the RSS of their σ beside the total's.

    Sanity of the component switches (can fail if an override leaks another
    component in): with the environment off, what is left of oblateness after
    the monitor removes the closed-form model is far below the total (< 1/3 of
    its meridional σ here: 0.1′-level against ≈ 3′), and a flight with the
    weather alone on a sphere differs from one with the layer height alone.
    """
    settings = campaign.Settings(_document(), "2024-01-15T00:00:00Z", 10.0, 0.03)
    tasks = campaign.plan([200], 1, True)
    assert {task.component for task in tasks} == set(campaign.COMPONENTS)
    for task in tasks:
        table, _ = campaign.run_task(settings, task)
        campaign.write_result(tmp_path, task, table)
    result = campaign.budget(tmp_path, tasks)
    components = result["components"]
    assert set(components) == set(campaign.COMPONENTS)
    meridional = {name: components[name]["year"]["meridional"]["sigma_arcmin"] for name in components}
    assert meridional["oblateness"] < meridional["total"] / 3.0
    assert meridional["weather"] != meridional["height"]
    rss = result["rss"]["year"]["meridional"]
    parts = [name for name in campaign.COMPONENTS if name != "total"]
    assert rss["rss_sigma_arcmin"] == pytest.approx(math.sqrt(sum(meridional[p] ** 2 for p in parts)))
    assert rss["total_sigma_arcmin"] == meridional["total"]
    assert set(result["by_day"]) == set(campaign.COMPONENTS) and "latitude_day" in result
    # What the star tracker's reasons cost the total's samples: its task's own counts over its samples.
    total = next(task for task in tasks if task.component == "total")
    _, description = campaign.read_result(campaign.task_path(tmp_path, total))
    assert {reason: cost["samples"] for reason, cost in result["truth_lost"].items()} == \
        {key[len("truth_lost_"):]: count for key, count in description["truth_lost"].items()}
    for cost in result["truth_lost"].values():
        assert cost["share"] == pytest.approx(cost["samples"] / description["samples"])
    files = campaign.write_budget(tmp_path, result)
    assert all((tmp_path / name).stat().st_size > 0 for name in files)


def test_the_flight_senses_in_the_sensor_nodes_blocks():
    """The flight groups samples as the stepped sensor node does, so the weather field rounds alike."""
    from pmv_ros.nodes.pipeline import Pipeline

    overrides = {"sensor.rate_hz": 10.0}
    values = flight_values(_document(), overrides)
    with Pipeline(METEOR, overrides, collect=False) as pipeline:
        assert pipeline.sensor.fast_time_block == sense_block(values.sensor)
        pipeline.step(1)
        assert pipeline.sensor.samples_computed_ahead == sense_block(values.sensor) - 1


def test_the_flights_stamps_are_the_wires():
    """What the flight gives the tracker and the monitor is what the nodes read off a message and off /clock."""
    from builtin_interfaces.msg import Time

    from pmv_msgs_shim.conversions import time_from_msg, write_stamp

    t = np.concatenate([np.arange(0.0, 200.0, 0.1), np.cumsum(np.full(3000, 0.1)), [45.9, 55.9, 1e6 + 0.999999999]])
    messages = [write_stamp(Time(), value) for value in t.tolist()]
    assert wire_stamps(t).tolist() == [time_from_msg(m) for m in messages]
    assert wire_clock(t).tolist() == [(m.sec * 1_000_000_000 + m.nanosec) * 1e-9 for m in messages]
