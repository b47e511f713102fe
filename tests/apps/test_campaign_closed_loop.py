"""``pmv campaign --closed-loop``: the flight closes the loop as the pipeline does; task files and the budget."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yaml
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped

import pmv_msgs_shim as shim
from pmv_ros.apps import campaign
from pmv_ros.apps.campaign.results import METADATA_KEY, POINTING_COLUMNS
from pmv_ros.nodes.pipeline import Pipeline
from pmv_ros.runtime.flight import flight_values, fly_closed_loop

from node_harness import probe

REPO = Path(__file__).resolve().parents[2]
KONDOR = REPO / "config" / "kondor.yaml"


def test_the_flight_closes_the_loop_as_the_pipeline_does():
    # The same runtimes driven the same way: the plant stepped to each sample's time with the last measurement,
    # the sensor following it. The pipeline's messages carry whole nanoseconds, the flight float seconds:
    # the truth buffer takes a stamp within 1 ns as the sample's instant, so the two sense the same attitudes
    # (1e-12 rad: float rounding through the messages' fields).
    overrides = {"seed": 4, "sensor.rate_hz": 2.0}
    samples = 300
    flight = fly_closed_loop(flight_values(yaml.safe_load(KONDOR.read_text()), overrides), samples)
    with Pipeline(KONDOR, overrides, closed_loop=True) as pipeline:
        got = probe(pipeline, {"pmv/attitude": Vector3Stamped, "attitude/truth": QuaternionStamped})
        pipeline.step(samples)
    sensed = np.array([shim.read_attitude_angles(m) for m in got["pmv/attitude"]]).T
    assert np.allclose(sensed[0], flight.t_s, rtol=0.0, atol=1e-9)
    assert np.allclose(sensed[1], flight.sensed_roll_rad, rtol=0.0, atol=1e-12, equal_nan=True)
    assert np.allclose(sensed[2], flight.sensed_pitch_rad, rtol=0.0, atol=1e-12, equal_nan=True)
    from pmv_ros.physics.attitude import true_roll_pitch

    truth = {round(t, 6): q for t, q in (shim.read_attitude_quaternion(m) for m in got["attitude/truth"])}
    true = np.array([true_roll_pitch(truth[round(t, 6)]) for t in flight.t_s]).T
    assert np.allclose(true[0], flight.true_roll_rad, rtol=0.0, atol=1e-12)
    assert np.allclose(true[1], flight.true_pitch_rad, rtol=0.0, atol=1e-12)


@pytest.mark.parametrize("overrides", [{"attitude.follow_timeout_s": 0.95}, {"input.max_rate_hz": 5.0}],
                         ids=["timeout-below-the-period", "rate-limit-below-the-control-rate"])
def test_the_flight_gives_the_sensor_every_plant_state_as_its_subscription_would(overrides):
    # A sensor at 1 Hz, the plant at 10 Hz: ten states a sample, each checked by the sensor as a message. With
    # a truth time-out below the sample period the states furthest ahead of the sensor's clock are refused as
    # future stamps, with a rate limit below the control rate some as too fast; the ones it keeps still give
    # every sample its attitude, as in the pipeline, where the sensor's subscription takes every state.
    values = flight_values(yaml.safe_load(KONDOR.read_text()), {"seed": 4, "sensor.rate_hz": 1.0, **overrides})
    flight = fly_closed_loop(values, 60)
    assert flight.t_s.size == 60 and np.isfinite(flight.sensed_pitch_rad).mean() > 0.9


@pytest.fixture(scope="module")
def closed_campaign(tmp_path_factory):
    out = tmp_path_factory.mktemp("campaign")
    settings = campaign.Settings(yaml.safe_load(KONDOR.read_text()), "2013-09-10T00:00:00Z", 2.0, 0.02,
                                 closed_loop=True)
    tasks = campaign.plan([15, 200], 1, components=False)
    campaign.check(settings, tasks)
    campaign.prepare_folder(out, settings)
    for task in tasks:
        table, _ = campaign.run_task(settings, task)
        campaign.write_result(out, task, table)
    return out, settings, tasks


def test_a_closed_loop_task_file_carries_the_pointing_and_is_trusted(closed_campaign):
    out, settings, tasks = closed_campaign
    table, description = campaign.check_result(campaign.task_path(out, tasks[0]), settings, tasks[0])
    assert table.column_names[-2:] == list(POINTING_COLUMNS)
    roll = table.column("pointing_roll_rad").to_numpy()
    settle = 4.0 / (0.7 * 2 * np.pi * 0.02)
    t = table.column("t_s").to_numpy()
    assert np.isnan(roll[t < settle]).all() and np.isfinite(roll[t >= settle]).all()
    assert description["pointing"]["roll"]["count"] == int(np.isfinite(roll).sum())
    assert json.loads((out / "campaign.json").read_text())["closed_loop"] is True


def test_a_tampered_pointing_column_is_not_trusted(closed_campaign, tmp_path):
    out, settings, tasks = closed_campaign
    path = campaign.task_path(out, tasks[0])
    table = pq.read_table(path)
    roll = table.column("pointing_roll_rad").to_numpy().copy()
    roll[np.isfinite(roll)] += 1e-5  # 0.03′ everywhere: the mean no longer agrees with the summary
    index = table.column_names.index("pointing_roll_rad")
    tampered = table.set_column(index, "pointing_roll_rad", pa.array(roll)).replace_schema_metadata(
        {METADATA_KEY: table.schema.metadata[METADATA_KEY]})
    copy = tmp_path / path.name
    pq.write_table(tampered, copy)
    with pytest.raises(campaign.ResultRejected, match="pointing roll mean_arcmin"):
        campaign.check_result(copy, settings, tasks[0])
    # An open-loop campaign's settings do not take a closed-loop file (and the digest differs anyway).
    open_settings = campaign.Settings(settings.document, settings.epoch_utc, 2.0, 0.02)
    with pytest.raises(campaign.ResultRejected):
        campaign.check_result(path, open_settings, tasks[0])


def test_the_budget_adds_the_pointing_by_season_and_day(closed_campaign):
    out, settings, tasks = closed_campaign
    result = campaign.budget(out, tasks, settings)
    pointing = result["pointing"]["total"]
    counts = [campaign.check_result(campaign.task_path(out, t), settings, t)[1]["pointing"]["pitch"]["count"]
              for t in tasks]
    assert pointing["year"]["pitch"]["count"] == sum(counts)
    assert pointing["year"]["roll"]["sigma_arcmin"] > 0.0
    assert set(result["pointing_by_day"]["total"]) == {"15", "200"}
    files = campaign.write_budget(out, result)
    assert "pointing.png" in files and (out / "pointing.png").stat().st_size > 10_000
