"""``sensor_node``: the PMV horizon sensor in a ROS 2 graph.

Propagates the orbit on the ROS clock (or on its own simulation clock in
fast-time mode, publishing ``/clock``), takes the body attitude from its own
profile (published on ``/attitude/truth``) or follows the user's
``/attitude/truth``, runs the four chords through the instrument model and
publishes crossings, roll/pitch (corrected and uncorrected), odometry and
health. All physics is in :mod:`pmv_ros.core`; all message layout in
:mod:`pmv_msgs_shim`.

Chord faults (issue 6): a chord whose half-plane has no horizon (a large
attitude excursion), whose scan found no crossing, or that has the Sun or the
Moon within ``sensor.bright_body_exclusion_deg`` of its swept arc is invalid:
its point on ``/pmv/horizon_crossings`` is NaN, and the angle of its pair
(roll for ±Y, pitch for ±X) is NaN on ``/pmv/attitude`` — the other pair's
angle is still published. ``/diagnostics`` names the chord and the cause
(and the body) as soon as the condition starts and again when it ends; the
chord is used again by itself as soon as it is valid.

Follow mode validates ``/attitude/truth``: non-finite or far-from-unit
quaternions, zero, future, duplicate and backward stamps are dropped and
counted per reason on ``/diagnostics`` (a stamp older than the latest by more
than ``attitude.follow_timeout_s`` is a restarted source and accepted).

QoS: outputs are reliable, keep-last 100 — deep enough for a fast-time
pipeline that is drained every tick, bounded in memory.
"""

from __future__ import annotations

import math
import sys
from collections import deque

import numpy as np
from geometry_msgs.msg import PolygonStamped, QuaternionStamped, Vector3Stamped
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg

import pmv_msgs_shim as shim
from .base import PmvNode
from ..core.attitude_profile import AttitudeProfile
from ..core.constants import ARCMIN_RAD, EARTH_ROTATION_RATE_RAD_S, GRS80, SPHERE
from ..core.orbit import CircularOrbit
from ..core.correction import load_correction
from ..core.environment import YEAR_DAYS, EnvironmentParameters
from ..core.ephemeris import SECONDS_PER_DAY, Epoch
from ..core.monitor import Status, validate_quaternion
from ..core.sensor import (BRIGHT_BODIES, ChainDetector, ChordStatus, RadianceConfig, SensorConfig, SensorModel,
                           nominal_scan_start_nadir_rad)
from ..core.geometry import CHORD_NAMES
from .launch import run_node
from .params import ParamSpec, ParameterError, declare, install_validation


#: Parameters of sensor_node (units in the names; YAML speaks km, deg, arcmin).
PARAMS = (
    ParamSpec("orbit.altitude_km", 500.0, "circular orbit altitude above the 6371 km mean radius", 150.0, 40000.0, unit="km"),
    ParamSpec("orbit.inclination_deg", 74.5, "orbit inclination", 0.0, 180.0, unit="deg"),
    ParamSpec("orbit.raan_deg", 0.0, "right ascension of the ascending node at epoch", -360.0, 360.0, unit="deg"),
    ParamSpec("orbit.u0_deg", 0.0, "argument of latitude at the start of the run", -360.0, 360.0, unit="deg"),
    ParamSpec("orbit.j2_node_drift", False, "apply the secular J2 drift of the node"),
    ParamSpec("attitude.source", "profile", "profile: own attitude model published on /attitude/truth; "
              "follow: take the attitude from /attitude/truth", choices=("profile", "follow")),
    ParamSpec("attitude.roll_offset_arcmin", 0.0, "constant roll of the body", -2700.0, 2700.0, unit="arcmin"),
    ParamSpec("attitude.pitch_offset_arcmin", 0.0, "constant pitch of the body", -2700.0, 2700.0, unit="arcmin"),
    ParamSpec("attitude.yaw_offset_arcmin", 0.0, "constant yaw of the body", -2700.0, 2700.0, unit="arcmin"),
    ParamSpec("attitude.roll_amplitude_arcmin", 0.0, "amplitude of the slow roll oscillation", 0.0, 2700.0, unit="arcmin"),
    ParamSpec("attitude.pitch_amplitude_arcmin", 0.0, "amplitude of the slow pitch oscillation", 0.0, 2700.0, unit="arcmin"),
    ParamSpec("attitude.oscillation_period_s", 600.0, "period of the slow oscillations", 1.0, 1e6, unit="s"),
    ParamSpec("attitude.roll_drift_arcmin_per_h", 0.0, "linear drift of the body roll with time", -600.0, 600.0,
              unit="arcmin/h"),
    ParamSpec("attitude.pitch_drift_arcmin_per_h", 0.0, "linear drift of the body pitch with time", -600.0, 600.0,
              unit="arcmin/h"),
    ParamSpec("attitude.follow_timeout_s", 1.0, "in follow mode, truth older than this is stale", 0.01, 3600.0, unit="s"),
    ParamSpec("sensor.rate_hz", 10.0, "output rate of the sensor", 0.1, 100.0, unit="Hz"),
    ParamSpec("sensor.earth_model", "GRS80", "Earth figure for the horizon geometry", choices=("GRS80", "sphere")),
    ParamSpec("sensor.detector", "chain", "chain: the signal chain of physics.md §4; ideal: the geometric horizon "
              "of the emitting layer (geometry-only studies)", choices=("chain", "ideal")),
    ParamSpec("sensor.correction", "calibrated", "brightness-correction table: calibrated (the rig table), none, "
              "or the path of a CSV file del_arcmin,pop_arcmin",
              constraints="calibrated, none, or the path of a readable CSV file with columns del_arcmin,pop_arcmin"),
    ParamSpec("sensor.scan_margin_deg", 3.0, "scan start beyond the CO2 top + half IFOV (covers oblateness and "
              "attitude excursions)", 0.0, 20.0, unit="deg"),
    ParamSpec("sensor.bright_body_exclusion_deg", 3.0, "a chord is invalid while the Sun or the Moon is within this "
              "angle of its swept arc (IFOV half-width 1.1 + body radius 0.27 + stray-light margin); 0: no check",
              0.0, 45.0, unit="deg"),
    ParamSpec("sensor.layer_height_km", 40.0, "height of the emitting layer seen by the ideal detector", 0.0, 100.0,
              unit="km"),
    ParamSpec("radiance.source", "uniform", "uniform: one disc radiance everywhere; environment: climatology, "
              "weather and layer height on the rotating Earth", choices=("uniform", "environment")),
    ParamSpec("radiance.disc_ru", 2.4, "uniform source: Earth disc radiance (1 r.u. = 2.5 mW/(cm2 sr))", 0.1, 10.0,
              unit="r.u."),
    ParamSpec("radiance.window_height_km", 40.0, "uniform source: height of the window emitting layer", 0.0, 100.0,
              unit="km"),
    ParamSpec("radiance.probe_distance_km", 300.0, "environment: ground distance inside the horizon where the "
              "weather jump sits (physics.md §3.1 Model C)", 10.0, 2000.0, unit="km"),
    ParamSpec("environment.climatology", True, "latitude/season climatology (off: uniform 2.4 r.u.)"),
    ParamSpec("environment.weather", True, "correlated random weather field"),
    ParamSpec("environment.height_variation", True, "varying window-layer height, 40 ± 20 km"),
    ParamSpec("environment.relative_variability", 0.15, "weather: relative variability eta'", 0.0, 1.0),
    ParamSpec("environment.correlation_radius_km", 700.0, "weather and height: correlation radius", 10.0, 6371.0,
              unit="km"),
    ParamSpec("environment.time_scale_h", 24.0, "weather and height: time scale of change", 1.0 / 60.0, 1e5,
              unit="h"),
    ParamSpec("sim.epoch_utc", "2024-01-15T00:00:00Z", "UTC date and time at the start of the run (simulation "
              "time 0 in fast time): sets the season, the Earth's rotation and where the Sun and Moon are",
              constraints="an ISO 8601 date-time such as 2024-01-15T00:00:00Z, 1900 … 2100"),
    ParamSpec("sensor.oblateness_compensation", False, "subtract the closed-form oblateness model on board"),
    ParamSpec("sim.fast_time", False, "run on an own simulation clock as fast as allowed and publish /clock"),
    ParamSpec("sim.time_scale", 0.0, "fast time: multiple of real time (0 = as fast as the pipeline allows)",
              0.0, 1e6),
    ParamSpec("sim.start_time_s", 0.0, "fast time: simulation time at start (message stamps end at 2^31 s)",
              0.0, 2.0e9, unit="s"),
    ParamSpec("diagnostics_period_s", 1.0, "period of /diagnostics health reports", 0.1, 3600.0, unit="s"),
    ParamSpec("seed", 0, "seed of every random process of the sensor", 0, 2**31 - 1),
)

#: | |q| − 1 | up to which a followed truth quaternion is normalised; beyond it is rejected.
QUATERNION_NORM_TOLERANCE = 0.01

#: Samples computed per call of the instrument model in fast time with the
#: own attitude profile (amortises numpy overhead; the output is identical).
#: 512 samples cost ≈ 35 µs each against ≈ 70 µs in blocks of 64; a parameter
#: change discards the block.
FAST_TIME_BLOCK = 512

#: Paced fast time (sim.time_scale > 0): a block should take no longer than one
#: tick period, or /clock stops while it is computed (512 samples: ≈ 20–45 ms).
#: Blocks are sized with this cost per sample, the slow end of what these
#: machines do, and kept between 16 samples and FAST_TIME_BLOCK.
PACED_SAMPLE_COST_S = 100e-6


def parse_epoch(iso_string: str) -> Epoch:
    """The run epoch from ``sim.epoch_utc``; ValueError naming the parameter if it is not a date-time in range."""
    try:
        return Epoch.from_utc(iso_string)
    except ValueError as error:
        raise ValueError(f"sim.epoch_utc: {error}") from None


def build_models(values: dict):
    """Orbit, attitude profile and instrument model from parameter values; ValueError if inconsistent."""
    orbit = CircularOrbit(
        altitude_m=values["orbit.altitude_km"] * 1e3,
        inclination_rad=math.radians(values["orbit.inclination_deg"]),
        raan_rad=math.radians(values["orbit.raan_deg"]),
        arg_latitude_at_epoch_rad=math.radians(values["orbit.u0_deg"]),
        epoch_s=values["sim.start_time_s"] if values["sim.fast_time"] else values.get("_epoch_s", 0.0),
        j2_node_drift=values["orbit.j2_node_drift"],
    )
    per_hour = ARCMIN_RAD / 3600.0
    profile = AttitudeProfile(
        roll_offset_rad=values["attitude.roll_offset_arcmin"] * ARCMIN_RAD,
        pitch_offset_rad=values["attitude.pitch_offset_arcmin"] * ARCMIN_RAD,
        yaw_offset_rad=values["attitude.yaw_offset_arcmin"] * ARCMIN_RAD,
        roll_amplitude_rad=values["attitude.roll_amplitude_arcmin"] * ARCMIN_RAD,
        pitch_amplitude_rad=values["attitude.pitch_amplitude_arcmin"] * ARCMIN_RAD,
        oscillation_period_s=values["attitude.oscillation_period_s"],
        roll_drift_rad_s=values["attitude.roll_drift_arcmin_per_h"] * per_hour,
        pitch_drift_rad_s=values["attitude.pitch_drift_arcmin_per_h"] * per_hour,
    )
    epoch = parse_epoch(values["sim.epoch_utc"])  # parsed whatever the detector: a bad date is refused now
    # The clock's zero: simulation time 0 in fast time, the node start in real time.
    clock_epoch = Epoch(epoch.julian_date_utc - orbit.epoch_s / SECONDS_PER_DAY)
    detector = build_detector(values, orbit)
    config = SensorConfig(
        ellipsoid=GRS80 if values["sensor.earth_model"] == "GRS80" else SPHERE,
        ideal_layer_height_m=values["sensor.layer_height_km"] * 1e3,
        oblateness_compensation=values["sensor.oblateness_compensation"],
        bright_body_exclusion_rad=math.radians(values["sensor.bright_body_exclusion_deg"]),
        epoch=clock_epoch,
        scan_start_nadir_rad=None if detector is not None else nominal_scan_start_nadir_rad(
            orbit.altitude_m, math.radians(values["sensor.scan_margin_deg"])),
    )
    return orbit, profile, SensorModel(orbit, config, detector)


def build_detector(values: dict, orbit: CircularOrbit):
    """The horizon detector the parameters ask for (None for the ideal one); ValueError if inconsistent."""
    if values["sensor.detector"] == "ideal":
        return None
    epoch = parse_epoch(values["sim.epoch_utc"])
    # The clock reads orbit.epoch_s at the start of the run (0 in fast time, the node start
    # in real time); anchor season and Earth rotation there exactly. (Stepping the epoch back
    # by a real-time clock of ≈ 1.8e9 s would let the GRS80 and GMST rates drift apart by ≈ 0.9°.)
    zero_s = orbit.epoch_s
    day_at_clock_zero = (float(epoch.day_of_year(0.0)) - zero_s / SECONDS_PER_DAY) % YEAR_DAYS
    rotation_at_clock_zero = float(epoch.earth_rotation_angle(0.0)) - EARTH_ROTATION_RATE_RAD_S * zero_s
    environment = EnvironmentParameters(
        climatology_enabled=values["environment.climatology"],
        weather_enabled=values["environment.weather"],
        height_variation_enabled=values["environment.height_variation"],
        relative_variability=values["environment.relative_variability"],
        correlation_radius_m=values["environment.correlation_radius_km"] * 1e3,
        time_scale_s=values["environment.time_scale_h"] * 3600.0,
        epoch_day_of_year=day_at_clock_zero,
        seed=values["seed"],
    )
    radiance = RadianceConfig(
        source=values["radiance.source"],
        disc_radiance_ru=values["radiance.disc_ru"],
        window_height_m=values["radiance.window_height_km"] * 1e3,
        environment=environment,
        probe_distance_m=values["radiance.probe_distance_km"] * 1e3,
        earth_rotation_at_epoch_rad=rotation_at_clock_zero % (2.0 * math.pi),
    )
    try:
        correction = load_correction(values["sensor.correction"], orbit.altitude_m)
    except ValueError as error:
        raise ValueError(f"sensor.correction: {error}") from None
    return ChainDetector(orbit.altitude_m, radiance, correction, scan_margin_rad=math.radians(values["sensor.scan_margin_deg"]))


class SensorNode(PmvNode):
    """The PMV sensor: orbit + attitude → 4-chord crossings and roll/pitch.

    Args:
        external_drive: fast time stepped by the caller through :meth:`step`
            (``pmv simulate``) instead of by the node's own wall-clock timer.
    """

    def __init__(self, *, external_drive: bool = False, **kwargs):
        super().__init__("sensor_node", **kwargs)
        self._values = declare(self, PARAMS)
        self._external_drive = external_drive
        self._values["_epoch_s"] = self.get_clock().now().nanoseconds * 1e-9
        try:
            self._rebuild(self._values)
        except ValueError as error:  # a combination, a date or a file the ranges cannot check
            raise ParameterError(str(error)) from None
        install_validation(self, PARAMS, self._values, self._rebuild_live)

        self._pub_crossings = self.publisher(PolygonStamped, "/pmv/horizon_crossings")
        self._pub_attitude = self.publisher(Vector3Stamped, "/pmv/attitude")
        self._pub_attitude_raw = self.publisher(Vector3Stamped, "/pmv/attitude_uncorrected")
        self._pub_odometry = self.publisher(Odometry, "/orbit/odometry")
        self._pub_diagnostics = self.publisher(DiagnosticArray, "/diagnostics")
        self._pub_truth = None
        self._pub_clock = None
        self._latest_truth = None  # (stamp_s, unit q) in follow mode
        self._chord_problem_counts = [[0] * 4 for _ in ChordStatus]  # [status][chord]
        self._rejected = {}  # reason → count (fixed set of reasons: bounded)
        self._rejected_reported = 0
        self._samples_published = 0
        self._last_diagnostics_s = -math.inf
        self._last_condition = ()  # what the last /diagnostics said, to report changes at once
        self._pending = deque()  # precomputed fast-time samples
        # One message per topic, filled in place for every sample (rclpy serialises at publish).
        self._out = dict(truth=QuaternionStamped(), odometry=Odometry(), crossings=PolygonStamped(),
                         attitude=Vector3Stamped(), attitude_raw=Vector3Stamped(), clock=ClockMsg(),
                         diagnostics=DiagnosticArray())
        if self._values["attitude.source"] == "profile":
            self._pub_truth = self.publisher(QuaternionStamped, "/attitude/truth")
        else:
            self.subscription(QuaternionStamped, "/attitude/truth", self._on_truth)

        self._sim_time_s = self._values["sim.start_time_s"]
        self._timer = None
        if self._values["sim.fast_time"]:
            self._pub_clock = self.publisher(ClockMsg, "/clock")
            if not external_drive:
                self._start_fast_timer(self._values)
        else:
            self._timer = self.create_timer(1.0 / self._values["sensor.rate_hz"], self._on_real_time_tick)
        self.get_logger().info(
            f"sensor_node: H = {self._values['orbit.altitude_km']:g} km, i = {self._values['orbit.inclination_deg']:g}°, "
            f"{self._values['sensor.rate_hz']:g} Hz, attitude from {self._values['attitude.source']}, "
            f"{'fast time' if self._values['sim.fast_time'] else 'real time'}")

    # -- parameters ---------------------------------------------------------------------------

    def _rebuild(self, values: dict) -> None:
        self._orbit, self._profile, self._model = build_models(values)

    def _rebuild_live(self, values: dict) -> None:
        for fixed in ("attitude.source", "sim.fast_time"):
            if values[fixed] != self._values[fixed]:
                raise ValueError(f"{fixed} cannot change while the node runs (restart the node to change it)")
        if values["sim.fast_time"]:
            values = dict(values, **{"sim.start_time_s": self._values["sim.start_time_s"]})
        self._rebuild(values)
        self._pending.clear()
        timing = ("sensor.rate_hz", "sim.time_scale")
        if self._timer is not None and any(values[name] != self._values[name] for name in timing):
            self._timer.cancel()
            self.destroy_timer(self._timer)
            if values["sim.fast_time"]:
                self._start_fast_timer(values)
            else:
                self._timer = self.create_timer(1.0 / values["sensor.rate_hz"], self._on_real_time_tick)

    def _start_fast_timer(self, values: dict) -> None:
        scale = values["sim.time_scale"]
        period = 0.0 if scale == 0.0 else 1.0 / (values["sensor.rate_hz"] * scale)
        self._timer = self.create_timer(period, self.step, clock=Clock(clock_type=ClockType.STEADY_TIME))

    # -- inputs ---------------------------------------------------------------------------------

    def _now_s(self) -> float:
        """Now on the sensor's own clock: simulation time in fast time, the node clock otherwise."""
        if self._values["sim.fast_time"]:
            return self._sim_time_s
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_truth(self, message: QuaternionStamped) -> None:
        """Follow mode: keep the latest valid truth; drop and count bad messages."""
        try:
            record = shim.attitude_quaternion_from_msg(message)
        except ValueError:  # negative or non-finite stamp
            self._count_rejected(f"rejected_truth_{Status.ZERO_STAMP.value}")
            return
        q, status, _ = validate_quaternion(record.q_xyzw, QUATERNION_NORM_TOLERANCE)
        t_s, timeout = record.stamp_s, self._values["attitude.follow_timeout_s"]
        latest = self._latest_truth
        if status is Status.OK:
            if t_s <= 0.0:
                status = Status.ZERO_STAMP
            elif t_s > self._now_s() + timeout:
                status = Status.FUTURE_STAMP
            elif latest is not None and t_s == latest[0]:
                status = Status.DUPLICATE
            elif latest is not None and latest[0] - timeout <= t_s < latest[0]:
                # Older by more than the timeout: the source restarted on a new clock; take it.
                status = Status.BACKWARDS
        if status is not Status.OK:
            self._count_rejected(f"rejected_truth_{status.value}")
            return
        self._latest_truth = (t_s, q)

    def _count_rejected(self, reason: str) -> None:
        self._rejected[reason] = self._rejected.get(reason, 0) + 1

    # -- ticks ----------------------------------------------------------------------------------

    @property
    def sim_time_s(self) -> float:
        """Current simulation time of the fast-time clock, s."""
        return self._sim_time_s

    def step(self) -> None:
        """Fast time: advance the simulation clock by one sensor period and publish that sample."""
        period = 1.0 / self._values["sensor.rate_hz"]
        self._sim_time_s += period
        self._pub_clock.publish(shim.write_clock(self._out["clock"], self._sim_time_s))
        if self._values["attitude.source"] == "profile":
            if not self._pending:
                times = self._sim_time_s + period * np.arange(self.fast_time_block)
                self._pending = deque(self._sense_block(times, self._profile.quaternion(times)))
            self._publish_sample(*self._pending.popleft())
        else:
            self._sense_following(self._sim_time_s)

    @property
    def fast_time_block(self) -> int:
        """Samples the instrument model computes per call in fast time (see PACED_SAMPLE_COST_S).

        Stepped by a caller (the in-process pipeline) or as fast as possible:
        FAST_TIME_BLOCK; paced by the node's own timer: no longer than a tick.
        """
        scale = self._values["sim.time_scale"]
        if scale == 0.0 or self._external_drive:
            return FAST_TIME_BLOCK
        tick_s = 1.0 / (self._values["sensor.rate_hz"] * scale)
        return max(16, min(FAST_TIME_BLOCK, int(tick_s / PACED_SAMPLE_COST_S)))

    def _on_real_time_tick(self) -> None:
        now_s = self.get_clock().now().nanoseconds * 1e-9
        if self._values["attitude.source"] == "profile":
            times = np.array([now_s])
            self._publish_sample(*self._sense_block(times, self._profile.quaternion(times))[0])
        else:
            self._sense_following(now_s)

    def _sense_following(self, t_s: float) -> None:
        truth = self._latest_truth
        if truth is None or abs(t_s - truth[0]) > self._values["attitude.follow_timeout_s"]:
            self._count_rejected("skipped_no_fresh_truth")
            self._maybe_publish_diagnostics(t_s)
            return
        self._publish_sample(*self._sense_block(np.array([t_s]), truth[1][:, None])[0])

    def _sense_block(self, times: np.ndarray, q: np.ndarray) -> list:
        """Run the instrument for a block of samples; a list of per-sample tuples of plain values to publish.

        The arrays become Python floats and tuples here, once per block: the
        per-sample publishing path then does no numpy indexing.
        """
        reading = self._model.sense(times, q)
        position, velocity = self._orbit.state_eci(times)
        status = reading.chord_status
        blinding = reading.blinding_body
        valid = (status == ChordStatus.VALID).T
        # What a HorizonCrossings record would hold (NaN rows for invalid chords), checked for the whole block.
        line_of_sight = shim.checked_lines_of_sight(reading.line_of_sight_sensor.transpose(2, 1, 0), valid)
        columns = (
            times.tolist(),
            q.T.tolist(),
            line_of_sight.tolist(),
            reading.sensed_roll_rad.tolist(),
            reading.sensed_pitch_rad.tolist(),
            reading.sensed_roll_uncorrected_rad.tolist(),
            reading.sensed_pitch_uncorrected_rad.tolist(),
            status.T.tolist(),
            (np.full_like(status, -1) if blinding is None else blinding).T.tolist(),
            position.T.tolist(),
            velocity.T.tolist(),
        )
        return list(zip(*columns))

    def _publish_sample(self, t_s, q, line_of_sight, roll, pitch, roll_raw, pitch_raw, status, blinding,
                        position, velocity) -> None:
        out = self._out
        if self._pub_truth is not None:
            self._pub_truth.publish(shim.write_attitude_quaternion(out["truth"], t_s, shim.ORBITAL_FRAME, q))
        self._pub_odometry.publish(shim.write_orbit_state(out["odometry"], t_s, shim.ECI_FRAME, shim.BODY_FRAME,
                                                          position, velocity))
        self._pub_crossings.publish(shim.write_horizon_crossings(out["crossings"], t_s, shim.SENSOR_FRAME,
                                                                 line_of_sight))
        self._pub_attitude.publish(shim.write_attitude_angles(out["attitude"], t_s, shim.SENSOR_FRAME, roll, pitch))
        self._pub_attitude_raw.publish(shim.write_attitude_angles(out["attitude_raw"], t_s, shim.SENSOR_FRAME,
                                                                  roll_raw, pitch_raw))
        for chord, code in enumerate(status):
            self._chord_problem_counts[code][chord] += 1
        self._samples_published += 1
        self._maybe_publish_diagnostics(t_s, status, blinding)

    def _chord_problems(self, status, blinding) -> list[str]:
        """One phrase per invalid chord: which chord, and why."""
        problems = []
        for chord, code, body in zip(CHORD_NAMES, status, blinding):
            if code == ChordStatus.SUN_OR_MOON:
                problems.append(f"chord {chord}: {BRIGHT_BODIES[body]} in the field of view (within "
                                f"{self._values['sensor.bright_body_exclusion_deg']:g} deg)")
            elif code == ChordStatus.NO_HORIZON:
                problems.append(f"chord {chord}: no horizon in the scan")
            elif code == ChordStatus.NOT_DETECTED:
                problems.append(f"chord {chord}: no crossing detected")
        return problems

    def _maybe_publish_diagnostics(self, t_s: float, status=None, blinding=None) -> None:
        """Publish /diagnostics every diagnostics_period_s, and at once when the chords' condition changes."""
        condition = () if status is None else (tuple(status), tuple(blinding))
        due = (t_s - self._last_diagnostics_s >= self._values["diagnostics_period_s"]
               or t_s < self._last_diagnostics_s)  # the clock went back: a new run
        if not due and condition == self._last_condition:
            return
        self._last_diagnostics_s = t_s
        self._last_condition = condition
        problems = [] if status is None else self._chord_problems(status, blinding)
        values = {"samples_published": self._samples_published}
        if status is not None:
            values.update({f"chord_{chord}": ChordStatus(int(code)).name.lower()
                           for chord, code in zip(CHORD_NAMES, status)})
        for code in ChordStatus:
            if code != ChordStatus.VALID:
                for chord, count in zip(CHORD_NAMES, self._chord_problem_counts[code]):
                    if count:
                        values[f"{code.name.lower()}_{chord}"] = int(count)
        values.update(self._rejected)
        rejected_total = sum(n for reason, n in self._rejected.items() if reason.startswith("rejected_"))
        fresh_rejections = rejected_total > self._rejected_reported
        self._rejected_reported = rejected_total
        if status is None:
            problems.append("no sample: no fresh /attitude/truth to follow")
        elif fresh_rejections:
            problems.append("rejected /attitude/truth messages")
        level = shim.Level.WARN if problems else shim.Level.OK
        message = "; ".join(problems) if problems else "all chords valid"
        report = shim.HealthReport(stamp_s=t_s, statuses=(shim.HealthStatus(
            name="pmv_ros/sensor_node: horizon", level=level, message=message, hardware_id="pmv", values=values),))
        self._pub_diagnostics.publish(shim.write_health(self._out["diagnostics"], report))


def main(args=None) -> int:
    """Console script / ``ros2 run pmv_ros sensor_node``."""
    return run_node(SensorNode, "sensor_node", args)


if __name__ == "__main__":
    sys.exit(main())
