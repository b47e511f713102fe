"""Fly one stretch of orbit through the core, without ROS: what the three nodes compute, with their own code.

orbit → attitude profile → sensor model → star-tracker model → the monitor's
statistics, for one preset and one set of overrides — the models the nodes
build (:mod:`pmv_ros.runtime.common.assembly`), run by the same core pieces the nodes
run, fed the way the in-process pipeline (``pmv simulate``) feeds them, so a
flight gives the statistics the pipeline gives for the same preset, epoch
and seed. Used by ``pmv campaign``.

What each node does, and what runs it here:

* sensor_node (fast time, stepped): the node's own runtime,
  :class:`~pmv_ros.runtime.sensor.runtime.SensorRuntime`, stepped a block at
  a time (:meth:`~pmv_ros.runtime.sensor.runtime.SensorRuntime.step_block`:
  its clock summed step by step from ``sim.start_time_s``, the block its
  stream computes ahead at the block's first step), whole blocks to the last.
  A sample reads the same in any grouping (tests/physics/test_sample_grouping.py).
* star_tracker_node: the node's own runtime,
  :class:`~pmv_ros.runtime.tracker.runtime.TrackerRuntime`, fed the whole truth stream
  as one batch (:func:`tracker_frames`; the node feeds it one message at a
  time): the same frames, draws and releases, bit for bit. Frames not
  released when the flight ends are never seen by the monitor.
* error_monitor_node: the node's own runtime,
  :meth:`~pmv_ros.runtime.monitor.runtime.MonitorRuntime.add_stream` (the
  monitor's one path: validation, alignment and statistics), the released frames
  arriving just before the sensor sample of their tick, the node clock at
  each tick the sample's stamp, and the orbit's state at each stamp as the
  odometry the node validates and takes its oblateness model from; every
  frame's outcome (``/star_tracker/frame_status``) counts the samples without
  truth by the tracker's reason (:mod:`pmv_ros.runtime.monitor.lost_truth`).

Message stamps in the pipeline are whole nanoseconds; here they are the
float times. The difference moves the statistics by ≈ 1e-9 arcmin.
The closed loop (:func:`fly_closed_loop`, ``pmv campaign --closed-loop``) adds
attitude_controller_node's runtime, :class:`~pmv_ros.runtime.control.ControllerRuntime`, and drives
the four as the in-process pipeline does (``pmv simulate --closed-loop``): before each sensor sample the
plant is stepped to the sample's time and its states go to the sensor in follow mode
(:meth:`~pmv_ros.runtime.sensor.runtime.SensorRuntime.add_truth`, then
:meth:`~pmv_ros.runtime.sensor.runtime.SensorRuntime.step`, one sample at a time), the sample's roll and
pitch to the controller; the plant's states are the truth stream of the star tracker and the monitor as
above. The true pointing error is taken at the sensor's sample times
(:class:`~pmv_ros.runtime.control.PointingStatistics`, after the loop's settling time).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..physics.attitude import true_roll_pitch
from ..physics.orbit.two_body import geocentric_latitude_longitude
from .common.assembly import (CONTROLLER_PARAMS, MONITOR_PARAMS, NODE_PARAMS, READ_CORRECTION, SENSOR_PARAMS,
                              STAR_TRACKER_PARAMS)
from .control import ControllerRuntime, PointingStatistics
from .monitor.runtime import MonitorRuntime
from .monitor.records import BATCH_STATUSES, PENDING_CODE, MonitorSummary
from .common.parameters import ParameterError, preset_values, unknown_parameter_problem
from .sensor.sample_stream import fast_time_block
from .sensor.runtime import SensorRuntime
from .tracker.runtime import TrackerFrames, TrackerRuntime, track_stream

#: Sample outcome codes in flight tables: the monitor's batch codes (0 is OK), PENDING_CODE still waiting at the end.
OUTCOME_CODES = BATCH_STATUSES

__all__ = ["OUTCOME_CODES", "PENDING_CODE", "Flight", "FlightValues", "TrackerFrames", "flight_values", "fly",
           "fly_closed_loop", "sense_block", "tracker_frames", "wire_clock", "wire_stamps"]


@dataclass(frozen=True)
class FlightValues:
    """Every node's parameter values for one flight (as :func:`flight_values` merges them)."""

    sensor: dict
    star_tracker: dict
    monitor: dict
    controller: dict | None = None  #: attitude_controller_node's (the closed loop)


def flight_values(document: dict, overrides: dict | None = None) -> FlightValues:
    """The three nodes' parameters from a parsed preset, as the in-process pipeline sets them.

    Like :class:`pmv_ros.nodes.pipeline.Pipeline`: fast time on for the
    sensor, each override given to the nodes that declare it (winning over
    the preset's sections); an override no node declares, or a key of the
    preset no node has, is refused. Raises
    :class:`~pmv_ros.runtime.common.parameters.ParameterError` (a ValueError) naming a
    bad value or key.
    """
    settings = {"sim.fast_time": True, **(overrides or {})}
    everyone = [spec for specs in NODE_PARAMS.values() for spec in specs]
    known = {spec.name for spec in everyone}
    for name in settings:
        problem = unknown_parameter_problem(name, "any pmv_ros node", known)
        if problem:
            raise ParameterError(problem)

    def node(name, specs):
        own = {spec.name for spec in specs}
        return preset_values(document, name, specs, {k: v for k, v in settings.items() if k in own},
                             shared_specs=everyone)

    return FlightValues(sensor=node("sensor_node", SENSOR_PARAMS),
                        star_tracker=node("star_tracker_node", STAR_TRACKER_PARAMS),
                        monitor=node("error_monitor_node", MONITOR_PARAMS),
                        controller=node("attitude_controller_node", CONTROLLER_PARAMS))


def _split(t_s) -> tuple[np.ndarray, np.ndarray]:
    """Whole seconds and nanoseconds of float times, as pmv_msgs_shim.conversions.write_stamp writes a stamp."""
    t = np.asarray(t_s, float)
    seconds = np.floor(t)
    nanoseconds = np.round((t - seconds) * 1e9)
    carry = nanoseconds >= 1e9
    return np.where(carry, seconds + 1.0, seconds), np.where(carry, nanoseconds - 1e9, nanoseconds)


def wire_stamps(t_s) -> np.ndarray:
    """Float times ``(N,)`` s as a node reads them back from a message stamp: ``sec + nanosec·1e-9``
    (pmv_msgs_shim.conversions.time_from_msg)."""
    seconds, nanoseconds = _split(t_s)
    return seconds + nanoseconds * 1e-9


def wire_clock(t_s) -> np.ndarray:
    """Float times ``(N,)`` s as a node's clock reads them when /clock carries them: its nanoseconds × 1e-9
    (pmv_ros.nodes.rclpy_internals.clock_now_s) — not always :func:`wire_stamps`' float."""
    seconds, nanoseconds = _split(t_s)
    return (seconds.astype(np.int64) * 1_000_000_000 + nanoseconds.astype(np.int64)) * 1e-9


def sense_block(sensor_values: dict) -> int:
    """Samples the sensor node senses per call when stepped in fast time (as ``pmv simulate`` steps it)."""
    return fast_time_block(sensor_values["sensor.rate_hz"], sensor_values["sim.time_scale"], stepped=True)


def tracker_frames(truth_s: np.ndarray, q_truth: np.ndarray, values: dict, start_s: float = 0.0,
                   orbit_states=None) -> TrackerFrames:
    """What star_tracker_node makes of a clean truth stream: its runtime fed the stream as one batch.

    Args:
        truth_s: ``(N,)`` increasing truth stamps, s, no gap longer than ``max_truth_gap_s``.
        q_truth: ``(4, N)`` true attitude (x, y, z, w) at those stamps.
        values: star_tracker_node parameter values.
        start_s: the node clock at start (outage windows are relative to it), s.
        orbit_states: with ``orbit.source`` follow, the spacecraft's states at the truth stamps — ``(3, N)``
            position (m) and ``(3, N)`` velocity (m/s) in ECI — as the odometry the tracker would hear.
    """
    truth_s = np.asarray(truth_s, float)
    steps = np.diff(truth_s)
    if steps.size and steps.max() > values["max_truth_gap_s"]:
        raise ValueError(f"truth samples {steps.max():g} s apart: the star tracker restarts its frames after "
                         f"max_truth_gap_s = {values['max_truth_gap_s']:g} s and would measure none "
                         "(a sensor rate of at least 1/max_truth_gap_s is needed)")
    runtime = TrackerRuntime(values, start_s)
    if runtime.orbit_buffer is not None:
        if orbit_states is None:
            raise ValueError("orbit.source = follow: the star tracker needs the spacecraft's states (orbit_states)")
        position, velocity = (np.asarray(a, float) for a in orbit_states)
        for k, t in enumerate(truth_s.tolist()):
            runtime.orbit_buffer.add(t, position[:, k], velocity[:, k])
    return track_stream(runtime, truth_s, q_truth)


@dataclass
class Flight:
    """One flight: per-sample arrays (rad, s) and the monitor's summary of it."""

    t_s: np.ndarray  #: (N,) sample stamps
    u_rad: np.ndarray  #: (N,) argument of latitude
    latitude_rad: np.ndarray  #: (N,) geocentric sub-satellite latitude
    sensed_roll_rad: np.ndarray  #: (N,) what the sensor published on /pmv/attitude
    sensed_pitch_rad: np.ndarray
    outcome: np.ndarray  #: (N,) int8 index into OUTCOME_CODES, PENDING_CODE for samples still waiting at the end
    roll_rad: np.ndarray  #: (N,) residuals as the statistics take them (offsets, oblateness removed as configured)
    pitch_rad: np.ndarray
    meridional_rad: np.ndarray
    summary: MonitorSummary
    frames: TrackerFrames
    truth_lost: dict  #: samples skipped for want of truth, by the star tracker's reason (``truth_lost_<reason>``)
    values: FlightValues = field(repr=False)
    #: the closed loop's true pointing error after the loop's settling time (None for an open loop), and the
    #: true roll and pitch at every sample (rad), the transient included
    pointing: PointingStatistics | None = None
    true_roll_rad: np.ndarray | None = None
    true_pitch_rad: np.ndarray | None = None


def fly(values: FlightValues, samples: int) -> Flight:
    """Fly ``samples`` sensor samples from the start of the run: the three nodes' work, no ROS.

    Args:
        values: every node's parameter values (:func:`flight_values`); the sensor's attitude source
            must be its own profile (follow mode has no truth to fly).
        samples: number of sensor samples (≥ 2).
    """
    sensor = values.sensor
    if sensor["attitude.source"] != "profile":
        raise ValueError("attitude.source = follow: a flight needs the sensor's own attitude profile")
    if samples < 2:
        raise ValueError(f"samples = {samples}: a flight needs at least 2")
    # The sensor: its own runtime stepped in fast time, a block at a time, whole blocks to the last.
    runtime = SensorRuntime(sensor, clock_epoch_s=0.0, correction=READ_CORRECTION, stepped=True)
    blocks = []
    for _ in range(-(-samples // runtime.fast_time_block)):
        times, attitude, reading = runtime.step_block()  # only what the flight keeps of each block
        blocks.append((times, attitude, reading.sensed_roll_rad, reading.sensed_pitch_rad))
    t, roll, pitch = (np.concatenate([block[k] for block in blocks])[:samples] for k in (0, 2, 3))
    q = np.concatenate([block[1] for block in blocks], axis=1)[:, :samples]
    orbit = runtime.orbit
    stamps = wire_stamps(t)  # /attitude/truth, /pmv/attitude and /orbit/odometry as the other nodes read them
    frames = tracker_frames(stamps, q, values.star_tracker, start_s=0.0)
    return _monitored(values, orbit, t, roll, pitch, frames)


def _monitored(values: FlightValues, orbit, t, roll, pitch, frames: TrackerFrames, **closed_loop) -> Flight:
    """The flight of the sensor's samples ``t``, ``roll``, ``pitch`` and the star tracker's ``frames``: the monitor's
    work on them (``closed_loop``: the :class:`Flight` fields of the pointing error)."""
    stamps = wire_stamps(t)
    published = np.flatnonzero(frames.released_at >= 0)  # in release order = frame order
    position, velocity = orbit.state_eci(t)  # what /orbit/odometry carries
    monitor = MonitorRuntime(values.monitor)  # as error_monitor_node takes the stream, all at once
    # /star_tracker/frame_status: every frame's outcome, heard before any sample it explains settles.
    monitor.lost_truth.add_frames(wire_stamps(frames.frame_s), frames.outcome)
    batch = monitor.add_stream(stamps, roll, pitch, wire_stamps(frames.frame_s[published]),
                               frames.q_measured[:, published], frames.released_at[published], position, velocity,
                               now_s=wire_clock(t))
    u = orbit.argument_of_latitude(t)
    latitude, _ = geocentric_latitude_longitude(position)
    return Flight(t, u, latitude, roll, pitch, batch.status, batch.roll_rad, batch.pitch_rad, batch.meridional_rad,
                  summary=monitor.monitor.summary(), frames=frames, truth_lost=monitor.truth_lost, values=values,
                  **closed_loop)


def fly_closed_loop(values: FlightValues, samples: int) -> Flight:
    """Fly ``samples`` sensor samples with the loop closed: the four nodes' work, no ROS (module docstring).

    Args:
        values: every node's parameter values (:func:`flight_values`); the sensor follows the plant whatever
            its ``attitude.source``.
        samples: number of sensor samples (≥ 2).
    """
    if samples < 2:
        raise ValueError(f"samples = {samples}: a flight needs at least 2")
    if values.sensor["orbit.source"] == "follow":
        raise ValueError("orbit.source = follow: a flight flies an orbit of its own")
    sensor = SensorRuntime(dict(values.sensor, **{"attitude.source": "follow"}), clock_epoch_s=0.0,
                           correction=READ_CORRECTION, stepped=True)
    # The pointing is taken at the sample times below, not at every control step.
    controller = ControllerRuntime(values.controller, start_s=sensor.sim_time_s, keep_pointing=False)
    period_s = 1.0 / values.sensor["sensor.rate_hz"]
    orbital, sensor_frame = sensor.frames.orbital, controller.frames.sensor
    truth_s, truth_q, kept = [], [], []
    for _ in range(samples):
        now_s = sensor.sim_time_s
        for state in controller.step_to(now_s + period_s).truth:  # the plant up to the coming sample
            sensor.add_truth(orbital, state.t_s, state.q_xyzw, now_s)
            truth_s.append(state.t_s)
            truth_q.append(state.q_xyzw)
        for sample in sensor.step().samples:
            controller.add_measurement(sensor_frame, sample.t_s, sample.roll_rad, sample.pitch_rad, sample.t_s)
            kept.append((sample.t_s, sample.roll_rad, sample.pitch_rad, *sample.q_xyzw))
    if len(kept) < samples:
        raise ValueError(f"the sensor measured {len(kept)} of {samples} samples: the loop lost its truth")
    table = np.array(kept, float).T
    t, roll, pitch, q = table[0], table[1], table[2], table[3:7]
    truth_s = np.array(truth_s)
    frames = tracker_frames(wire_stamps(truth_s), np.array(truth_q, float).T, values.star_tracker, start_s=0.0)
    # A frame released at a truth sample reaches the monitor before the sensor sample at that sample's time.
    released = frames.released_at >= 0
    arrival = np.where(released, np.searchsorted(t, truth_s[np.where(released, frames.released_at, 0)] - 1e-9), -1)
    frames = replace(frames, released_at=arrival)
    pointing = controller.new_pointing()
    pointing.add_many(t, q)
    true_roll, true_pitch = true_roll_pitch(q)
    return _monitored(values, sensor.orbit, t, roll, pitch, frames, pointing=pointing, true_roll_rad=true_roll,
                      true_pitch_rad=true_pitch)
