"""sensor_node's runtime without ROS: the samples and health it hands the node, and the campaign's agreement."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import yaml

from flights import REPO, preset_values
from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.runtime.common.assembly import read_correction
from pmv_ros.runtime.flight import flight_values, fly
from pmv_ros.runtime.common.records import Level
from pmv_ros.runtime.sensor.sample_stream import FAST_TIME_BLOCK
from pmv_ros.runtime.sensor.runtime import HealthAt, SamplePublication, SensorRuntime


def runtime_of(values: dict, **options) -> SensorRuntime:
    options.setdefault("clock_epoch_s", 0.0)
    options.setdefault("stepped", True)
    return SensorRuntime(values, correction=read_correction(values), **options)


def test_stepped_samples_are_the_campaign_flights_samples_bit_for_bit():
    # The campaign's flight steps the node's runtime a block at a time (step_block, arrays); the node steps it
    # sample by sample (step, rows): the same stamps, blocks and numbers (more than one block, so the block
    # boundary is crossed, and a last block cut short).
    document = yaml.safe_load((REPO / "config" / "kondor.yaml").read_text())
    values = flight_values(document, {"sensor.rate_hz": 10.0})
    count = FAST_TIME_BLOCK + 40
    runtime = runtime_of(values.sensor)
    samples = [sample for _ in range(count) for sample in runtime.step().samples]
    flight = fly(values, count)
    assert len(samples) == count
    assert np.array_equal([s.t_s for s in samples], flight.t_s)
    assert np.array_equal([s.roll_rad for s in samples], flight.sensed_roll_rad, equal_nan=True)
    assert np.array_equal([s.pitch_rad for s in samples], flight.sensed_pitch_rad, equal_nan=True)
    assert runtime.health.samples_published == count


def test_each_sample_counts_and_health_comes_every_period_with_the_nodes_graph_in_it():
    values = preset_values("kondor", sensor__rate_hz=10.0, diagnostics_period_s=1.0)
    problems = [(0, ())]
    runtime = runtime_of(values, graph_problems=lambda: problems[-1],
                         source_counters=lambda: {"other_source_attitude_truth": 3})
    published, health = 0, []
    for _ in range(35):
        for item in runtime.step().published:
            if isinstance(item, SamplePublication):
                published += 1
                assert item.sample.t_s == pytest.approx(runtime.sim_time_s)
                assert np.isclose(np.linalg.norm(item.imu.q_xyzw), 1.0) or np.isnan(item.sample.roll_rad)
            else:
                assert isinstance(item, HealthAt)
                assert int(item.health.values["samples_published"]) == published  # the sample just before
                assert item.health.values["other_source_attitude_truth"] == 3
                health.append(item)
    assert published == 35
    stamps = np.array([h.stamp_s for h in health])
    assert len(stamps) >= 3 and np.all(np.diff(stamps) <= 1.0 + 1e-9)
    # A second source the node's graph reports is an ERROR (asked again once a period has passed).
    problems.append((0, ("2 publishers of /attitude/truth",)))
    later = [item for _ in range(12) for item in runtime.step().health]
    assert later and later[-1].health.level is Level.ERROR
    assert "2 publishers of /attitude/truth" in later[-1].health.message
    # Someone else publishing the truth the own attitude model publishes: a warning that names follow mode.
    problems.append((1, ()))
    warned = [item for _ in range(12) for item in runtime.step().health][-1].health
    assert warned.level is Level.WARN and "Follow mode" in warned.message


def test_following_truth_is_checked_then_measured_at_the_sample_time():
    values = preset_values("kondor", attitude__source="follow", sensor__rate_hz=10.0, sensor__detector="ideal")
    runtime = runtime_of(values)
    orbital = runtime.frames.orbital
    q = np.array(quaternion_from_roll_pitch_yaw(10 * ARCMIN_RAD, -4 * ARCMIN_RAD, 0.0))
    assert not runtime.add_truth("eci", runtime.sim_time_s, q, 0.0).published
    assert not runtime.add_truth(orbital, None, q, 0.0).published
    counters = runtime.health.counters
    assert counters["rejected_truth_wrong_frame"] == 1 and counters["rejected_truth_zero_stamp"] == 1
    # No truth yet: a step publishes health only, and says why.
    nothing = runtime.step()
    assert nothing.samples == [] and "no sample" in nothing.health[-1].health.message
    angles = []
    for _ in range(20):
        runtime.add_truth(orbital, runtime.sim_time_s + 0.1, q, 0.0)
        angles += [(s.roll_rad, s.pitch_rad) for s in runtime.step().samples]
    assert len(angles) == 20
    np.testing.assert_allclose(angles, [[10 * ARCMIN_RAD, -4 * ARCMIN_RAD]] * 20, atol=0.05 * ARCMIN_RAD)
    # The truth stops: after the horizon the runtime goes stale, says so once on the log, and publishes nothing.
    outputs = [runtime.step() for _ in range(30)]
    stale_lines = [line for out in outputs for line in out.log if line.level == "error"]
    assert len(stale_lines) == 1 and "stale" in stale_lines[0].text
    assert outputs[-1].samples == []
    assert any(report.health.level is Level.ERROR and "stale" in report.health.message
               for out in outputs for report in out.health)


def test_real_time_ticks_give_every_grid_time_due_once_in_order():
    values = preset_values("kondor", sim__fast_time=False, sensor__rate_hz=10.0)
    runtime = runtime_of(values, clock_epoch_s=1000.0, stepped=False)
    first = runtime.tick(1000.35).samples
    assert [s.t_s for s in first] == pytest.approx([1000.3])  # the first tick: the latest grid time only
    later = runtime.tick(1000.62).samples
    assert [s.t_s for s in later] == pytest.approx([1000.4, 1000.5, 1000.6])
    assert runtime.tick(1000.64).samples == []  # nothing new is due
    assert runtime.health.samples_published == 4


def test_a_host_steps_the_follower_to_its_own_times_as_the_node_clock_would():
    # A simulator keeps its clock in integer nanoseconds; step_to measures at exactly its times, one call a step
    # or several as one block, what tick measures at the same grid times (both follow mode, real time).
    values = preset_values("kondor", sim__fast_time=False, attitude__source="follow", orbit__source="follow",
                           sensor__rate_hz=10.0, sensor__detector="ideal")
    stepped, ticked = runtime_of(values, stepped=False), runtime_of(values, stepped=False)
    orbit = runtime_of(preset_values("kondor", sim__fast_time=False)).orbit
    times = [k * 100_000_000 * 1e-9 for k in range(1, 31)]  # a zero stamp is 'unset', as on the wire
    angles = {"stepped": [], "ticked": []}
    for k, t_s in enumerate(times):
        q = quaternion_from_roll_pitch_yaw((5 + 0.1 * k) * ARCMIN_RAD, -3 * ARCMIN_RAD, 0.0)
        position, velocity = orbit.state_eci(t_s)
        for runtime in (stepped, ticked):
            runtime.add_truth(runtime.frames.orbital, t_s, q, t_s)
            runtime.add_odometry(runtime.frames.eci, runtime.frames.orbital, (t_s, position, velocity), t_s)
        if k >= 10:  # the first ten as one block, then one at a time
            angles["stepped"] += [(s.t_s, s.roll_rad)
                                  for s in stepped.step_to(times[:11] if k == 10 else [t_s]).samples]
            angles["ticked"] += [(s.t_s, s.roll_rad) for s in ticked.tick(t_s).samples]
    assert [t for t, _ in angles["stepped"]] == times
    steps = {round(t, 6): roll for t, roll in angles["stepped"]}
    assert all(steps[round(t, 6)] == roll for t, roll in angles["ticked"])  # tick: the latest time first
    assert angles["stepped"][-1][1] == pytest.approx(7.9 * ARCMIN_RAD, abs=0.05 * ARCMIN_RAD)
    with pytest.raises(ValueError, match="not after"):
        stepped.step_to([times[5]])
    with pytest.raises(ValueError, match="follow"):
        runtime_of(preset_values("kondor")).step_to([1.0])


def test_a_built_sensor_is_ready_its_first_sample_builds_nothing_of_the_chain():
    # The chain's one-off start (its tables: ≈ 0.07 s of CPU; its compiled kernels: loaded from numba's cache,
    # or compiled) is paid when the runtime is built, so a real-time node's first tick is on time: the first
    # sample finds everything built and compiles nothing.
    from pmv_ros.physics.chain import fast
    from pmv_ros.physics.instrument import sensing

    caches = (fast._kit, fast.response_tables, fast._ground_distance_table, fast._disc_sample_inverse)
    for cache in caches:
        cache.cache_clear()
    values = preset_values("kondor", sensor__rate_hz=10.0)
    runtime = runtime_of(values)
    built = [cache.cache_info().misses for cache in caches]
    assert all(built)  # (the kit twice: with the correction table, and without it by chain.prepare)
    kernels = {kernel: len(kernel.signatures) for kernel in (sensing.sense_samples, fast._sense_chords)}
    assert all(kernels.values())
    sample = runtime.step().samples[0]
    assert [cache.cache_info().misses for cache in caches] == built
    assert {kernel: len(kernel.signatures) for kernel in kernels} == kernels
    assert np.isfinite(sample.roll_rad) and np.isfinite(sample.pitch_rad)


@pytest.mark.parametrize("preset", ["kondor", "meteor_m2"])
def test_following_a_recorded_truth_history_reads_what_the_own_attitude_read(preset):
    # Issue 48: the own attitude (blocks of 512 computed ahead) publishes its truth at each sample time; a
    # follower fed that history, one truth message per sample, senses each sample alone — and a real-time
    # follower several due samples as one block. The flight environment and the Sun and Moon check on: the same
    # readings to 1e-6′ (what is left is rounding in the fields' nodes, computed in other batches).
    values = preset_values(preset, sensor__rate_hz=10.0)
    own = runtime_of(values)
    recorded = [sample for _ in range(700) for sample in own.step().samples]
    follower = runtime_of(dict(values, **{"attitude.source": "follow"}))
    followed = []
    for sample in recorded:
        follower.add_truth(follower.frames.orbital, sample.t_s, sample.q_xyzw, sample.t_s)
        followed += follower.step().samples
    # (the follower's clock is its steps summed, the own blocks' stamps first + k·period: 1e-13 s apart at most)
    np.testing.assert_allclose([s.t_s for s in followed], [s.t_s for s in recorded], rtol=0, atol=1e-9)
    assert [s.chord_status for s in followed] == [s.chord_status for s in recorded]
    for name in ("roll_rad", "pitch_rad", "roll_uncorrected_rad", "pitch_uncorrected_rad"):
        mine, theirs = (np.array([getattr(s, name) for s in samples]) for samples in (followed, recorded))
        assert np.nanmax(np.abs(mine - theirs)) / ARCMIN_RAD <= 1e-6, name
    assert np.std([s.pitch_rad for s in recorded]) / ARCMIN_RAD > 0.1  # the environment does move the angles


def test_a_sample_is_python_floats_whatever_its_attitude_and_orbit_come_from():
    # A node publishes a sample's fields into messages without numpy indexing (sample_stream's promise): its
    # stamp, attitude and angles are Python floats from the own profile's blocks, from a followed attitude, and
    # from the own profile on a followed orbit (one sample at a time, made from the profile's array).
    values = preset_values("kondor", sensor__rate_hz=10.0)
    own = runtime_of(values)
    follower = runtime_of(dict(values, **{"attitude.source": "follow"}))
    follower.add_truth(follower.frames.orbital, 0.1, (0.0, 0.0, 0.0, 1.0), 0.1)
    on_orbit = runtime_of(dict(values, **{"orbit.source": "follow"}))
    position, velocity = own.orbit.state_eci(0.1)
    on_orbit.add_odometry(on_orbit.frames.eci, on_orbit.frames.orbital, (0.1, position, velocity), 0.0)
    for runtime in (own, follower, on_orbit):
        (sample,) = runtime.step().samples
        assert type(sample.t_s) is float and type(sample.roll_rad) is float
        assert isinstance(sample.q_xyzw, tuple) and {type(c) for c in sample.q_xyzw} == {float}


def test_a_followed_orbits_field_nodes_placed_ahead_are_placed_again_when_odometry_arrives():
    # orbit.source follow, fast time, one sample a step. The first sample, at 0.1 s, is 0.05 s past the only
    # odometry: it is sensed on the extrapolated state, and the field nodes it and the next samples need are
    # placed from that state. Then the user's orbit determination corrects the orbit (from 0.1 s on, its states
    # are 1 km further along the track). The nodes placed from the extrapolation are placed again once the new
    # odometry arrives: the samples after read as those of a sensor that had the corrected odometry from the
    # start, to 1e-6′ (kept, the sample at 0.2 s differs by 0.08′: the horizon points 1 km off, against fields of
    # ≥ 100 km).
    values = preset_values("meteor_m2", orbit__source="follow", sensor__rate_hz=10.0, orbit__j2_node_drift=False)
    first = runtime_of(preset_values("meteor_m2", orbit__j2_node_drift=False)).orbit
    shift_rad = 1e3 / first.radius_m
    corrected = dataclasses.replace(first, arg_latitude_at_epoch_rad=first.arg_latitude_at_epoch_rad + shift_rad)
    early, informed = runtime_of(values), runtime_of(values)

    def odometry(runtime, orbit, stamps):
        for t_s in stamps:
            position, velocity = orbit.state_eci(t_s)
            runtime.add_odometry(runtime.frames.eci, runtime.frames.orbital, (t_s, position, velocity), 0.0)

    odometry(early, first, [0.05])
    extrapolated = early.step().samples  # 0.1 s: extrapolated from 0.05 s
    odometry(early, corrected, np.arange(0.1, 2.01, 0.1))
    odometry(informed, first, [0.05])
    odometry(informed, corrected, np.arange(0.1, 2.01, 0.1))
    informed.step()  # 0.1 s: the corrected state
    after = {name: [sample for _ in range(15) for sample in runtime.step().samples]
             for name, runtime in (("early", early), ("informed", informed))}
    assert len(extrapolated) == 1 and len(after["early"]) == len(after["informed"]) == 15
    for mine, theirs in zip(after["early"], after["informed"]):
        assert mine.t_s == pytest.approx(theirs.t_s, abs=1e-9)
        assert max(abs(mine.roll_rad - theirs.roll_rad), abs(mine.pitch_rad - theirs.pitch_rad)) / ARCMIN_RAD <= 1e-6
