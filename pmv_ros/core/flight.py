"""Fly one stretch of orbit through the core, without ROS: what the three nodes compute, in batch.

orbit → attitude profile → sensor model → star-tracker model → the monitor's
statistics, for one preset and one set of overrides — the same models the
nodes build (:mod:`pmv_ros.core.assembly`), fed the same way the in-process
pipeline (``pmv simulate``) feeds them, so a flight here gives the
statistics the pipeline gives for the same preset, epoch and seed. Used by
``pmv campaign``.

What the nodes do between the core and their topics, and how it is done here:

* sensor_node (fast time): sample k (k = 1 … N) at ``sim.start_time_s +
  k / sensor.rate_hz``; the true attitude from the profile; the model senses
  them in the node's blocks (:data:`SENSE_BLOCK`: the weather and layer-height
  fields refer their float32 phases to each block's first time, so another
  grouping moves roll by ≈ 2e-4′).
* star_tracker_node: :func:`tracker_frames` — frames on the tracker's own
  grid, the truth slerped to each frame between the two truth samples that
  bracket it, the inertial rate of that turn, measured by
  :class:`~pmv_ros.core.star_tracker.StarTracker` frame by frame in the
  order and grouping the node uses (one call per truth sample that makes
  frames), so the same seed gives the same draws; released ``latency_s``
  after the frame, so frames not yet released when the flight ends are not
  used.
* error_monitor_node: :func:`account_flight` — the alignment and statistics
  of :class:`~pmv_ros.core.monitor.ErrorMonitor` on whole arrays (truth
  interpolated linearly between the bracketing released frames, never
  across ``max_truth_gap_s``; a sample without truth after
  ``max_truth_wait_s`` given up; offsets and the closed-form oblateness model
  removed as configured; running statistics and the last orbit's harmonics).
  The per-sample monitor costs ≈ 12 µs a sample, half the sensor model, so a
  batch form is what makes the campaign fast; ``tests/test_campaign.py``
  holds it to the per-sample monitor sample by sample. The orbit position
  for the oblateness model is the orbit's own (what /orbit/odometry carries).

Message stamps in the pipeline are whole nanoseconds; here they are the
float times. The difference moves the statistics by ≈ 1e-9 arcmin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .assembly import (MONITOR_PARAMS, SENSOR_PARAMS, STAR_TRACKER_PARAMS, build_models, build_monitor,
                       build_tracker)
from .attitude import (quaternion_conjugate, quaternion_from_rotation_vector, quaternion_product,
                       rotation_vector_from_quaternion, true_roll_pitch)
from .constants import EARTH_MEAN_RADIUS_M, GM_EARTH_M3_S2
from .ground_error import nadir_ground_error
from .monitor import CHANNELS, COUNTER_NAMES, ChannelSummary, MonitorSummary, Status
from .oblateness import closed_form_oblateness
from .orbit import geocentric_latitude_longitude
from .parameters import preset_values
from .star_tracker import Outcome, inertial_rate_of_nadir_pointing
from .statistics import DEFAULT_MAX_CONDITION, RunningStatistics, harmonic_amplitudes

#: Samples the sensor model computes per call: sensor_node's FAST_TIME_BLOCK (512). The weather and layer-height
#: fields evaluate float32 phases relative to a block's first time, so other groupings round differently
#: (≈ 2e-4′ in roll): the blocks are the node's. (The node should take this constant from here.)
SENSE_BLOCK = 512

#: Grid tolerance of the star tracker's frame clock, s (a frame at t + 1e-12 still belongs to t).
FRAME_TOLERANCE_S = 1e-12

#: Release tolerance of the star tracker's latency queue, s.
RELEASE_TOLERANCE_S = 1e-9

#: Sample outcome codes in flight tables: 0 is OK, then the monitor's skip reasons, -1 still pending at the end.
OUTCOME_CODES = (Status.OK, Status.NO_VALID_ANGLE, Status.NO_TRUTH, Status.TRUTH_GAP, Status.STALE_TRUTH)
PENDING_CODE = -1


@dataclass(frozen=True)
class FlightValues:
    """Every node's parameter values for one flight (as :func:`flight_values` merges them)."""

    sensor: dict
    star_tracker: dict
    monitor: dict


def flight_values(document: dict, overrides: dict | None = None) -> FlightValues:
    """The three nodes' parameters from a parsed preset, as the in-process pipeline sets them.

    Like :class:`pmv_ros.nodes.pipeline.Pipeline`: fast time on, ``overrides``
    given to every node (each takes the ones it declares) and winning over
    the preset's sections. Raises :class:`~pmv_ros.core.parameters.ParameterError`
    (a ValueError) naming a bad value.
    """
    settings = {"sim.fast_time": True, **(overrides or {})}
    return FlightValues(
        sensor=preset_values(document, "sensor_node", SENSOR_PARAMS, settings),
        star_tracker=preset_values(document, "star_tracker_node", STAR_TRACKER_PARAMS, settings),
        monitor=preset_values(document, "error_monitor_node", MONITOR_PARAMS, settings),
    )


def frame_attitudes(previous_s, q_previous, current_s, q_current, frame_s, mean_motion_rad_s: float):
    """The truth at star-tracker frames between two truth samples, and the rate of that turn (physics.md §6).

    A constant-rate turn (slerp) from ``q_previous`` at ``previous_s`` to
    ``q_current`` at ``current_s``; the rate for the tracker's limit is the
    turn's rate plus the orbital frame's own (nadir pointing).

    One truth pair in plain floats (what star_tracker_node does per truth
    sample): ``q_*`` tuples (x, y, z, w), ``frame_s`` a list of times →
    (list of quaternion tuples, rate float). Arrays (a batch of pairs, one
    per frame): ``q_*`` ``(4, M)``, times ``(M,)`` → (``(4, M)``, ``(M,)``).
    """
    if isinstance(q_previous, tuple):
        dt = current_s - previous_s
        turn = rotation_vector_from_quaternion(quaternion_product(q_current, quaternion_conjugate(q_previous)))
        rate = inertial_rate_of_nadir_pointing(mean_motion_rad_s, tuple(w / dt for w in turn))
        return [quaternion_product(quaternion_from_rotation_vector(tuple((t - previous_s) / dt * w for w in turn)),
                                   q_previous) for t in frame_s], rate
    dt = current_s - previous_s
    turn = rotation_vector_from_quaternion(quaternion_product(q_current, quaternion_conjugate(q_previous)))
    q_frames = quaternion_product(quaternion_from_rotation_vector(turn * ((frame_s - previous_s) / dt)), q_previous)
    return q_frames, inertial_rate_of_nadir_pointing(mean_motion_rad_s, turn / dt)


@dataclass(frozen=True)
class TrackerFrames:
    """Star-tracker frames of a flight: stamps (s), measured quaternions ``(4, M)``, outcome codes, release times."""

    frame_s: np.ndarray
    q_measured: np.ndarray
    outcome: np.ndarray
    release_s: np.ndarray


def tracker_frames(truth_s: np.ndarray, q_truth: np.ndarray, values: dict, start_s: float = 0.0) -> TrackerFrames:
    """What star_tracker_node makes of a clean truth stream: frames on its grid, measured, with release times.

    The frame grid starts at the first multiple of the frame period at or
    after the first truth stamp; each frame takes the truth slerped between
    the truth samples just before and at or after it (a constant-rate turn),
    and that turn's inertial rate for the rate limit; frames are measured in
    groups — the frames one truth sample completes — in stamp order, which is
    how the node draws its noise. A frame is released (published) at the
    first truth sample at or after frame + ``latency_s``.

    Args:
        truth_s: ``(N,)`` increasing truth stamps, s, no gap longer than ``max_truth_gap_s``.
        q_truth: ``(4, N)`` true attitude (x, y, z, w) at those stamps.
        values: star_tracker_node parameter values.
        start_s: the node clock at start (outage windows are relative to it), s.
    """
    truth_s = np.asarray(truth_s, float)
    q_truth = np.asarray(q_truth, float)
    steps = np.diff(truth_s)
    if steps.size and steps.max() > values["max_truth_gap_s"]:
        raise ValueError(f"truth samples {steps.max():g} s apart: the star tracker restarts its frames after "
                         f"max_truth_gap_s = {values['max_truth_gap_s']:g} s and would measure none "
                         "(a sensor rate of at least 1/max_truth_gap_s is needed)")
    period = 1.0 / values["rate_hz"]
    tracker = build_tracker(values, start_s)
    empty = TrackerFrames(np.empty(0), np.empty((4, 0)), np.empty(0, np.int8), np.empty(0))
    if truth_s.size < 2:
        return empty
    first = math.ceil(truth_s[0] / period) * period
    count = int(math.floor((truth_s[-1] + FRAME_TOLERANCE_S - first) / period)) + 1
    frames = first + period * np.arange(max(count, 0))
    # The truth sample that completes each frame: the first one at or after it (never the first sample).
    after = np.maximum(np.searchsorted(truth_s + FRAME_TOLERANCE_S, frames, side="left"), 1)
    frames, after = frames[after < truth_s.size], after[after < truth_s.size]
    if frames.size == 0:
        return empty
    before = after - 1
    mean_motion = math.sqrt(GM_EARTH_M3_S2 / (EARTH_MEAN_RADIUS_M + values["orbit.altitude_km"] * 1e3) ** 3)
    q_frames, rate = frame_attitudes(truth_s[before], q_truth[:, before], truth_s[after], q_truth[:, after], frames,
                                     mean_motion)
    measured = np.empty((4, frames.size))
    outcome = np.empty(frames.size, np.int8)
    # Group boundaries: frames completed by the same truth sample are measured in one call, as the node does.
    starts = np.flatnonzero(np.r_[True, after[1:] != after[:-1]])
    ends = np.r_[starts[1:], frames.size]
    frame_list, q_list, rate_list = frames.tolist(), q_frames.T.tolist(), rate.tolist()
    for lo, hi in zip(starts.tolist(), ends.tolist()):
        if hi - lo == 1:
            q_one, code = tracker.measure(frame_list[lo], tuple(q_list[lo]), rate_list[lo])
            measured[:, lo], outcome[lo] = q_one, code
        else:
            measured[:, lo:hi], outcome[lo:hi] = tracker.measure(frames[lo:hi], q_frames[:, lo:hi], rate[lo:hi])
    release_index = np.searchsorted(truth_s + RELEASE_TOLERANCE_S, frames + values["latency_s"], side="left")
    release = np.where(release_index < truth_s.size, truth_s[np.minimum(release_index, truth_s.size - 1)], np.inf)
    return TrackerFrames(frames, measured, outcome, release)


@dataclass
class Flight:
    """One flight: per-sample arrays (rad, s) and the monitor's summary of it."""

    t_s: np.ndarray  #: (N,) sample stamps
    u_rad: np.ndarray  #: (N,) argument of latitude
    latitude_rad: np.ndarray  #: (N,) geocentric sub-satellite latitude
    outcome: np.ndarray  #: (N,) int8 index into OUTCOME_CODES, PENDING_CODE for samples still waiting at the end
    roll_rad: np.ndarray  #: (N,) residuals as the statistics take them (offsets, oblateness removed as configured)
    pitch_rad: np.ndarray
    meridional_rad: np.ndarray
    summary: MonitorSummary
    frames: TrackerFrames
    values: FlightValues = field(repr=False)


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
    orbit, profile, model = build_models(sensor)
    period = 1.0 / sensor["sensor.rate_hz"]
    t = orbit.epoch_s + period * np.arange(1, samples + 1)
    q = profile.quaternion(t)
    roll = np.empty(samples)
    pitch = np.empty(samples)
    for lo in range(0, samples, SENSE_BLOCK):
        reading = model.sense(t[lo:lo + SENSE_BLOCK], q[:, lo:lo + SENSE_BLOCK])
        roll[lo:lo + SENSE_BLOCK] = reading.sensed_roll_rad
        pitch[lo:lo + SENSE_BLOCK] = reading.sensed_pitch_rad
    frames = tracker_frames(t, q, values.star_tracker, start_s=0.0)
    u = orbit.argument_of_latitude(t)
    if sensor["sensor.oblateness_compensation"] or values.monitor["sensor.oblateness_compensation"]:
        model_roll = model_pitch = np.zeros(samples)  # removed on board already: the monitor removes nothing
    else:
        _, model_roll, model_pitch = closed_form_oblateness(u, orbit.altitude_m, orbit.inclination_rad)
    position, _ = orbit.state_eci(t)
    latitude, _ = geocentric_latitude_longitude(position)
    accounted = account_flight(t, roll, pitch, frames, values.monitor, model_roll, model_pitch, orbit.altitude_m)
    return Flight(t, u, latitude, *accounted, frames=frames, values=values)


def account_flight(t_s, sensed_roll_rad, sensed_pitch_rad, frames: TrackerFrames, monitor_values: dict,
                   oblateness_roll_rad, oblateness_pitch_rad, altitude_m: float):
    """The error monitor's alignment and statistics over a whole flight, on arrays.

    Returns ``(outcome, roll, pitch, meridional, summary)``: per-sample
    outcome codes (see :data:`OUTCOME_CODES`) and the residuals that enter
    the statistics (NaN where not used), and a
    :class:`~pmv_ros.core.monitor.MonitorSummary` as the monitor's
    ``summary()`` gives it at the end of the flight.
    """
    monitor = build_monitor(monitor_values)  # the monitor's configuration, validated as the node does
    config = monitor.config
    t = np.asarray(t_s, float)
    n = t.size
    released = frames.outcome == Outcome.OK
    released &= np.isfinite(frames.release_s) & (frames.release_s <= t[-1])
    truth_t = frames.frame_s[released]
    truth_roll, truth_pitch = true_roll_pitch(frames.q_measured[:, released])
    truth_roll, truth_pitch = np.atleast_1d(truth_roll), np.atleast_1d(truth_pitch)
    release_s = frames.release_s[released]

    outcome = np.full(n, PENDING_CODE, np.int8)
    no_angle = np.isnan(sensed_roll_rad) & np.isnan(sensed_pitch_rad)
    after = np.searchsorted(truth_t, t, side="left")  # the first released frame at or after each stamp
    covered = after < truth_t.size
    # Sentinels past the last frame keep the indexing below in range; covered samples never use them.
    frame_t = np.r_[truth_t, np.inf]
    frame_roll, frame_pitch = np.r_[truth_roll, np.nan], np.r_[truth_pitch, np.nan]
    # Frames are released in stamp order: the covering frame is the first to arrive. Until then a
    # sample waits; on a tick more than max_truth_wait_s after its stamp it is given up.
    arrival = np.where(covered, np.r_[release_s, np.inf][after], np.inf)
    last_tick = np.where(covered, _last_tick_before(t, arrival), t[-1])
    stale = ~no_angle & (last_tick - t > config.max_truth_wait_s)
    exact = covered & (frame_t[after] == t)
    no_truth = covered & ~exact & (after == 0)
    span = frame_t[after] - np.r_[np.nan, truth_t][after]  # NaN before the first frame
    gap = covered & ~exact & ~no_truth & (span > config.max_truth_gap_s)
    live = ~no_angle & ~stale & covered
    used = live & ~no_truth & ~gap
    outcome[no_angle] = OUTCOME_CODES.index(Status.NO_VALID_ANGLE)
    outcome[stale] = OUTCOME_CODES.index(Status.STALE_TRUTH)
    outcome[live & no_truth] = OUTCOME_CODES.index(Status.NO_TRUTH)
    outcome[live & gap] = OUTCOME_CODES.index(Status.TRUTH_GAP)
    outcome[used] = OUTCOME_CODES.index(Status.OK)

    # Truth at each used stamp: the frame itself, or linear between the bracketing frames.
    index = np.flatnonzero(used)
    hi = after[index]
    lo = np.maximum(hi - 1, 0)
    hit = exact[index]
    weight = np.where(hit, 0.0, (t[index] - frame_t[lo]) / np.where(hit, 1.0, frame_t[hi] - frame_t[lo]))
    truth_r = np.where(hit, frame_roll[hi], frame_roll[lo] + weight * (frame_roll[hi] - frame_roll[lo]))
    truth_p = np.where(hit, frame_pitch[hi], frame_pitch[lo] + weight * (frame_pitch[hi] - frame_pitch[lo]))
    residual_roll = np.asarray(sensed_roll_rad, float)[index] - truth_r
    residual_pitch = np.asarray(sensed_pitch_rad, float)[index] - truth_p
    roll_kept = residual_roll - config.roll_offset_rad
    pitch_kept = residual_pitch - config.pitch_offset_rad
    model_roll = np.broadcast_to(np.asarray(oblateness_roll_rad, float), t.shape)[index]
    model_pitch = np.broadcast_to(np.asarray(oblateness_pitch_rad, float), t.shape)[index]
    kept = (roll_kept, pitch_kept, np.hypot(roll_kept, pitch_kept))  # hypot of a NaN is NaN, as in the monitor
    roll_removed, pitch_removed = roll_kept - model_roll, pitch_kept - model_pitch
    removed = (roll_removed, pitch_removed, np.hypot(roll_removed, pitch_removed))

    primary = config.remove_oblateness
    reported = removed if primary else kept
    columns = [np.full(n, np.nan) for _ in CHANNELS]
    for column, values in zip(columns, reported):
        column[index] = values

    counters = dict.fromkeys(COUNTER_NAMES, 0)
    counters["sensor_received"] = n
    counters["truth_received"] = int(truth_t.size)
    counters["used"] = int(index.size)
    counters["used_one_angle"] = int(np.count_nonzero(np.isnan(residual_roll) | np.isnan(residual_pitch)))
    for status in OUTCOME_CODES[1:]:
        counters[f"skipped_{status.value}"] = int(np.count_nonzero(outcome == OUTCOME_CODES.index(status)))
    channels = []
    ring_t = t[index]
    amplitudes = _last_orbit_harmonics(ring_t, reported, config)
    for k, name in enumerate(CHANNELS):
        angle = RunningStatistics()
        angle.update(reported[k])
        ground = RunningStatistics()
        if math.isfinite(altitude_m) and altitude_m > 0.0:
            ground.update(_ground_component(reported[0], reported[1], altitude_m, k))
        harmonics = {int(h): float(a) for h, a in zip(config.harmonics, amplitudes[:, k])}
        channels.append(ChannelSummary(name, angle.count, angle.mean, angle.sigma, angle.three_sigma,
                                       angle.max_abs, harmonics, ground.mean, ground.sigma, ground.max_abs))
    full_orbit = bool(ring_t.size) and _full_orbit(ring_t, config)
    summary = MonitorSummary(primary, tuple(channels), counters, full_orbit)
    return outcome, columns[0], columns[1], columns[2], summary


def _last_tick_before(t: np.ndarray, arrival: np.ndarray) -> np.ndarray:
    """The latest sensor stamp before ``arrival`` (a sample can only be given up on a tick before its truth)."""
    index = np.searchsorted(t, arrival, side="left") - 1
    return np.where(index >= 0, t[np.clip(index, 0, t.size - 1)], -np.inf)


def _ground_component(roll, pitch, altitude_m: float, channel: int) -> np.ndarray:
    """Cross-track (roll), along-track (pitch) or circular (meridional) ground error, m, as the monitor splits it."""
    roll = np.asarray(roll, float)
    pitch = np.asarray(pitch, float)
    error = nadir_ground_error(np.where(np.isnan(roll), 0.0, roll), np.where(np.isnan(pitch), 0.0, pitch), altitude_m)
    if channel == 0:
        return np.where(np.isnan(roll), np.nan, error.cross_track_m)
    if channel == 1:
        return np.where(np.isnan(pitch), np.nan, error.along_track_m)
    return np.where(np.isnan(roll) | np.isnan(pitch), np.nan, error.circular_m)


def _absolute_bins(t: np.ndarray, config) -> np.ndarray:
    return np.floor(t / (config.orbital_period_s / config.harmonic_bins)).astype(np.int64)


def _full_orbit(t: np.ndarray, config) -> bool:
    bins = _absolute_bins(t, config)
    return bool(bins[-1] - bins[0] >= config.harmonic_bins - 1)


def _last_orbit_harmonics(t: np.ndarray, channels, config) -> np.ndarray:
    """Harmonic amplitudes of the last orbit as the monitor's ring gives them, ``(len(harmonics), 3)``.

    The ring (:class:`~pmv_ros.core.statistics.OrbitRing`) keeps, per bin of
    the last ``harmonic_bins`` bins, the mean stamp and mean value of the
    samples in it, and fits the harmonics to those means; NaN until a full orbit.
    """
    result = np.full((len(config.harmonics), len(CHANNELS)), np.nan)
    if t.size == 0 or not _full_orbit(t, config):
        return result
    bins = _absolute_bins(t, config)
    in_orbit = bins > bins[-1] - config.harmonic_bins
    origin = t[0]
    omega = 2.0 * math.pi / config.orbital_period_s
    for k, values in enumerate(channels):
        keep = in_orbit & np.isfinite(values)
        if not keep.any():
            continue
        slots, inverse = np.unique(bins[keep], return_inverse=True)
        counts = np.bincount(inverse).astype(float)
        mean_time = np.bincount(inverse, weights=t[keep] - origin) / counts
        means = np.bincount(inverse, weights=values[keep]) / counts
        result[:, k] = harmonic_amplitudes(omega * mean_time, means, config.harmonics,
                                           max_gap_fraction=config.max_harmonic_gap_fraction,
                                           max_condition=DEFAULT_MAX_CONDITION)
    return result
