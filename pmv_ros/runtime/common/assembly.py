"""Preset → models: every node's parameters and the models built from their values, ROS-free.

The nodes declare these specs and call these builders; the CLI, the campaign
and the tests call them without rclpy (``preset_values`` in
:mod:`pmv_ros.runtime.common.parameters` reads a params file the way rclpy merges it).
"""

from __future__ import annotations

import math
from dataclasses import replace

from ...physics.attitude_profile import AttitudeProfile
from ...physics.constants import ARCMIN_RAD, EARTH_ROTATION_RATE_RAD_S, GRS80, SECONDS_PER_DAY, SPHERE
from ...physics.instrument.correction import load_correction
from ...physics.environment import CLIMATOLOGY_SAMPLINGS, YEAR_DAYS, EnvironmentParameters
from ...physics.orbit.ephemeris import Epoch, raan_from_local_time_of_node
from .orbit_buffer import FollowedOrbit, OrbitBuffer
from ...physics.orbit.two_body import MAX_ALTITUDE_M, MIN_ALTITUDE_M, CircularOrbit
from .controller_params import controller_params
from .frames import FRAME_PARAMS, MOUNTING_PARAMS, Mounting
from .parameters import ParamSpec
from .truth_buffer import DEFAULT_BRIDGE_S
from ...physics.orbit.tle import TleOrbit, element_set_altitude_m
from ...physics.instrument.sensor import (ChainDetector, RadianceConfig, SensorConfig, SensorModel,
                                          nominal_scan_start_nadir_rad)
from ...physics.star_tracker import SOLAR_EVENTS
from .validation import InputBounds


#: Input guards every node has (the checks are runtime/common/validation.py). Read-only while the node runs:
#: anyone on the DDS domain can set parameters, and a guard a neighbour could loosen guards nothing.
INPUT_PARAMS = (
    ParamSpec("input.max_rate_hz", 500.0, "an input stream stamped faster than this is thinned to it and the rest "
              "counted too_fast (a flood cannot run the stream's clock ahead)", 2.0, 1e5, unit="Hz", read_only=True),
    ParamSpec("input.source_timeout_s", 1.0, "only the first publisher heard on an input is used; it is given up "
              "after this long without a message (then the next one heard is used)", 0.05, 3600.0, unit="s",
              read_only=True),
)

#: Plausibility bounds of the monitor's inputs: what a horizon sensor on a bound Earth orbit can report.
#: What a state on orbit/odometry must be to be read (the monitor's, and the sensor's with orbit.source follow).
ORBIT_BOUND_PARAMS = (
    ParamSpec("input.min_orbit_radius_km", 6471.0, "smallest geocentric radius on /orbit/odometry", 6371.0, 1e6,
              unit="km", read_only=True),
    ParamSpec("input.max_orbit_radius_km", 50000.0, "largest geocentric radius on /orbit/odometry", 6371.0, 1e6,
              unit="km", read_only=True),
    ParamSpec("input.min_orbit_speed_km_s", 0.5, "smallest inertial speed on /orbit/odometry", 0.0, 100.0,
              unit="km/s", read_only=True),
    ParamSpec("input.max_orbit_speed_km_s", 11.2, "largest inertial speed on /orbit/odometry (an unbound state "
              "is refused whatever the speed)", 0.0, 100.0, unit="km/s", read_only=True),
)

MONITOR_INPUT_PARAMS = (
    ParamSpec("input.max_abs_angle_deg", 30.0, "a /pmv/attitude roll or pitch beyond this is not a measurement "
              "(the PMV sees no horizon there) and is dropped", 0.1, 180.0, unit="deg", read_only=True),
) + ORBIT_BOUND_PARAMS


def orbit_bounds(values: dict, **others) -> InputBounds:
    """The input bounds of ``values``' orbit/odometry parameters (:data:`ORBIT_BOUND_PARAMS`), and ``others``."""
    return InputBounds(min_orbit_radius_m=values["input.min_orbit_radius_km"] * 1e3,
                       max_orbit_radius_m=values["input.max_orbit_radius_km"] * 1e3,
                       min_orbit_speed_m_s=values["input.min_orbit_speed_km_s"] * 1e3,
                       max_orbit_speed_m_s=values["input.max_orbit_speed_km_s"] * 1e3, **others)


#: The orbit's altitude and inclination: one range and default; each node says what it takes them for.
ORBIT_ALTITUDE = ParamSpec("orbit.altitude_km", 500.0, "circular orbit altitude above the 6371 km mean radius",
                           150.0, 40000.0, unit="km", read_only=True)
ORBIT_INCLINATION = ParamSpec("orbit.inclination_deg", 74.5, "orbit inclination", 0.0, 180.0, unit="deg",
                              read_only=True)

#: Where the sensor's orbit comes from (interfaces.md "Orbit sources").
ORBIT_SOURCES = ("circular", "tle", "follow")

#: Roll and pitch error RMS of the Kondor preset (the defaults fly its orbit), arcmin: the defaults of
#: ``imu.*_error_rms_arcmin`` (config/kondor.yaml says how they were measured).
IMU_DEFAULT_RMS_ARCMIN = (5.81, 7.96)

#: Parameters of sensor_node (units in the names; YAML speaks km, deg, arcmin).
SENSOR_PARAMS = INPUT_PARAMS + FRAME_PARAMS + MOUNTING_PARAMS + ORBIT_BOUND_PARAMS + (
    ORBIT_ALTITUDE,
    ORBIT_INCLINATION,
    ParamSpec("orbit.raan_deg", 0.0, "right ascension of the ascending node at epoch", -360.0, 360.0, unit="deg",
              read_only=True),
    ParamSpec("orbit.u0_deg", 0.0, "argument of latitude at the start of the run", -360.0, 360.0, unit="deg",
              read_only=True),
    ParamSpec("orbit.j2_node_drift", False, "apply the secular J2 drift of the node", read_only=True),
    ParamSpec("orbit.ltan_h", -1.0, "local mean solar time of the ascending node at the epoch (sun-synchronous "
              "orbits): sets the node from the mean Sun instead of orbit.raan_deg; negative: not used",
              -1.0, 24.0, unit="h", read_only=True),
    ParamSpec("orbit.source", "circular", "circular: the circular orbit of orbit.altitude_km … u0_deg; tle: SGP4 "
              "from orbit.tle_line1/2 (sim.epoch_utc is the run's start; the circular elements are not used); "
              "follow: the state from the user's orbit/odometry, interpolated to each sample (orbit.altitude_km is "
              "then the nominal altitude the scan is set for)", choices=ORBIT_SOURCES, read_only=True),
    ParamSpec("orbit.extrapolation_s", 2.0, "orbit.source follow: how far past the newest odometry the two-body "
              "motion is carried before the orbit is stale (no output, an ERROR)", 0.0, 60.0, unit="s",
              read_only=True),
    ParamSpec("orbit.follow_timeout_s", 10.0, "orbit.source follow: no interpolation between odometry states "
              "further apart", 0.01, 600.0, unit="s", read_only=True),
    ParamSpec("orbit.tle_line1", "", "orbit.source tle: line 1 of the two-line element set (69 columns)",
              constraints="line 1 of a two-line element set, 69 columns with its checksum", read_only=True),
    ParamSpec("orbit.tle_line2", "", "orbit.source tle: line 2 of the two-line element set (69 columns)",
              constraints="line 2 of a two-line element set, 69 columns with its checksum", read_only=True),
    ParamSpec("attitude.source", "profile", "profile: own attitude model published on /attitude/truth; "
              "follow: take the attitude from /attitude/truth", choices=("profile", "follow"), read_only=True),
    ParamSpec("attitude.roll_offset_arcmin", 0.0, "constant roll of the body", -2700.0, 2700.0, unit="arcmin"),
    ParamSpec("attitude.pitch_offset_arcmin", 0.0, "constant pitch of the body", -2700.0, 2700.0, unit="arcmin"),
    ParamSpec("attitude.yaw_offset_arcmin", 0.0, "constant yaw of the body", -2700.0, 2700.0, unit="arcmin"),
    ParamSpec("attitude.roll_amplitude_arcmin", 0.0, "amplitude of the slow roll oscillation", 0.0, 2700.0,
              unit="arcmin"),
    ParamSpec("attitude.pitch_amplitude_arcmin", 0.0, "amplitude of the slow pitch oscillation", 0.0, 2700.0,
              unit="arcmin"),
    ParamSpec("attitude.oscillation_period_s", 600.0, "period of the slow oscillations", 1.0, 1e6, unit="s"),
    ParamSpec("attitude.roll_drift_arcmin_per_h", 0.0, "linear drift of the body roll with time", -600.0, 600.0,
              unit="arcmin/h"),
    ParamSpec("attitude.pitch_drift_arcmin_per_h", 0.0, "linear drift of the body pitch with time", -600.0, 600.0,
              unit="arcmin/h"),
    ParamSpec("attitude.extrapolation_periods", 2.0, "in follow mode, how far past the newest truth the last body "
              "rate is carried as a matter of course, in truth periods (further, up to attitude.extrapolation_s, "
              "it bridges a late truth sample and is counted truth_bridged)", 0.0, 10.0),
    ParamSpec("attitude.extrapolation_s", DEFAULT_BRIDGE_S, "in follow mode, how far past the newest truth the last "
              "body rate is carried at most (a scheduler hiccup of the attitude stack; the longer of this and "
              "extrapolation_periods applies, never beyond follow_timeout_s); later the truth is stale and no "
              "angles are published", 0.0, 10.0, unit="s"),
    ParamSpec("attitude.follow_timeout_s", 1.0, "in follow mode, no interpolation across a truth gap longer than this "
              "and no extrapolation further; also the tolerance of future stamps", 0.01, 3600.0, unit="s"),
    ParamSpec("sensor.rate_hz", 10.0, "output rate of the sensor", 0.1, 100.0, unit="Hz"),
    ParamSpec("sensor.earth_model", "GRS80", "Earth figure for the horizon geometry", choices=("GRS80", "sphere"),
              read_only=True),
    ParamSpec("sensor.detector", "chain", "chain: the signal chain of physics.md §4; ideal: the geometric horizon "
              "of the emitting layer (geometry-only studies)", choices=("chain", "ideal")),
    ParamSpec("sensor.correction", "calibrated", "brightness-correction table: calibrated (the rig table), "
              "meteor_m2_2 (the working curve x s, the gain error inferred for Meteor-M No.2-2), none, "
              "or the path of a CSV file del_arcmin,pop_arcmin",
              constraints="calibrated, meteor_m2_2, none, or the path of a readable CSV file with columns "
                          "del_arcmin,pop_arcmin", read_only=True),
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
    ParamSpec("environment.climatology", True, "latitude/season climatology (off: uniform 2.4 r.u.)"),
    ParamSpec("environment.climatology_sampling", "horizon", "where a chord takes the climatology: horizon (once, "
              "at its horizon point, a level scaling its whole profile, as the flight records show) or "
              "line_of_sight (also where its lines of sight below the horizon meet the ground)",
              choices=CLIMATOLOGY_SAMPLINGS),
    ParamSpec("environment.weather", True, "correlated random weather field"),
    ParamSpec("environment.height_variation", True, "varying window-layer height, 40 km with sigma 10 km (uniform)"),
    ParamSpec("environment.relative_variability", 0.15, "weather: relative variability eta = sigma_B/B_mean at a "
              "point (radiance kept inside 1 ... 4 r.u.)", 0.0, 1.0),
    ParamSpec("environment.correlation_radius_km", 700.0, "weather: e-folding distance of its correlation",
              10.0, 6371.0, unit="km"),
    ParamSpec("environment.synoptic_fraction", 0.0, "weather: share of its variance in the synoptic band of "
              "zones (0: exponential weather)", 0.0, 0.95),
    ParamSpec("environment.synoptic_zone_km", 2000.0, "weather: length of the synoptic zones along the track",
              500.0, 10000.0, unit="km"),
    ParamSpec("environment.height_correlation_radius_km", 700.0, "window-layer height: e-folding distance of its "
              "correlation (independent of the weather)", 10.0, 6371.0, unit="km"),
    ParamSpec("environment.time_scale_h", 24.0, "weather and height: time scale of change", 1.0 / 60.0, 1e5,
              unit="h"),
    ParamSpec("sim.epoch_utc", "2024-01-15T00:00:00Z", "UTC date and time at the start of the run (simulation "
              "time 0 in fast time): sets the season, the Earth's rotation and where the Sun and Moon are",
              constraints="an ISO 8601 date-time such as 2024-01-15T00:00:00Z, 1900 … 2100", read_only=True),
    ParamSpec("sim.flight_record", "", "the flight record this preset reproduces: pmv simulate --report draws its "
              "published points on spectrum.png (pmv_ros/data/flight_records.json); empty: none",
              choices=("", "meteor_m2_121163", "meteor_m2_2_229"), read_only=True),
    ParamSpec("sensor.oblateness_compensation", False, "subtract the closed-form oblateness model on board"),
    ParamSpec("sim.fast_time", False, "run on an own simulation clock as fast as allowed and publish /clock",
              read_only=True),
    ParamSpec("sim.time_scale", 0.0, "fast time: multiple of real time (0 = as fast as the pipeline allows)",
              0.0, 1e6),
    ParamSpec("sim.start_time_s", 0.0, "fast time: simulation time at start (message stamps end at 2^31 s)",
              0.0, 2.0e9, unit="s", read_only=True),
    ParamSpec("diagnostics_period_s", 1.0, "period of /diagnostics health reports", 0.1, 3600.0, unit="s"),
    ParamSpec("seed", 0, "seed of every random process of the sensor", 0, 2**31 - 1, read_only=True),
    # The defaults are the default orbit's (Kondor's, 500 km, 74.5°); each preset states its own budget.
    ParamSpec("imu.roll_error_rms_arcmin", IMU_DEFAULT_RMS_ARCMIN[0], "/pmv/attitude_imu: root mean square of the "
              "sensor's roll error (sensed - true, oblateness included unless compensated on board); its square is "
              "the roll variance of orientation_covariance", 0.001, 600.0, unit="arcmin"),
    ParamSpec("imu.pitch_error_rms_arcmin", IMU_DEFAULT_RMS_ARCMIN[1], "/pmv/attitude_imu: root mean square of the "
              "sensor's pitch error; its square is the pitch variance of orientation_covariance", 0.001, 600.0,
              unit="arcmin"),
)


#: Most outage windows (entries of outage_start_s / outage_duration_s): a handful of operator overrides; the bound
#: keeps a peer from filling memory.
MAX_OUTAGES = 64

#: The sensor's orbit and epoch parameters the tracker takes too (one spec each; a preset shares them in ``/**``).
SHARED_WITH_SENSOR = ("orbit.inclination_deg", "orbit.raan_deg", "orbit.u0_deg", "orbit.j2_node_drift",
                      "orbit.ltan_h", "orbit.source", "orbit.tle_line1", "orbit.tle_line2", "orbit.extrapolation_s",
                      "orbit.follow_timeout_s", "sim.epoch_utc", "sim.fast_time", "sim.start_time_s")

#: Named solar proton events (:data:`pmv_ros.physics.star_tracker.SOLAR_EVENTS`), "custom" or none.
SOLAR_EVENT_CHOICES = ("",) + tuple(SOLAR_EVENTS) + ("custom",)

_UTC = "an ISO 8601 date-time such as 2000-11-09T15:55:00Z, 1900 … 2100"

#: Parameters of star_tracker_node.
STAR_TRACKER_PARAMS = INPUT_PARAMS + ORBIT_BOUND_PARAMS + FRAME_PARAMS + (
    replace(ORBIT_ALTITUDE, description="orbit altitude (the orbit the tracker flies; see orbit.source)"),
) + tuple(spec for spec in SENSOR_PARAMS if spec.name in SHARED_WITH_SENSOR) + (
    # Timing (physics.md §6 item 2).
    ParamSpec("frame_period_s", 1.0, "a frame every this long, on a grid of the truth stream's clock (frame time = "
              "the middle of the exposure) [A]", 0.02, 100.0, unit="s"),
    ParamSpec("exposure_s", 0.0, "exposure; 0: the optimum d·rho/(f·omega) = 171.9″/omega at the orbital rate "
              "(0.75 s at 500 km, 0.81 s at 835 km), at most frame_period_s", 0.0, 100.0, unit="s"),
    ParamSpec("processing_s", 0.5, "readout and processing: a frame is published exposure_s/2 + this after its "
              "time [A]", 0.0, 60.0, unit="s"),
    # Sky and detection (items 1, 3).
    ParamSpec("boresight_body", [0.0, 0.0, 1.0], "the boresight in the body frame (+Z: zenith when nadir "
              "pointing)", -1.0, 1.0, max_length=3),
    ParamSpec("field_of_view_deg", 7.81, "side of the square field (512 × 55″ [A: the format])", 0.5, 40.0,
              unit="deg"),
    ParamSpec("catalogue_stars", 8350, "on-board catalogue: the brightest Hipparcos-2 stars by Hp [T]", 3, 26547),
    ParamSpec("sky_stars", 26547, "stars of the sky the tracker can register (the rest are not drawn) [T: the "
              "stand's sky]", 3, 26547),
    ParamSpec("detection_margin_mag", 1.0, "detection limit at rest above the catalogue's faintest Hp [A]",
              -3.0, 5.0, unit="mag"),
    ParamSpec("max_rate_arcsec_s", 600.0, "hard ceiling of the trail rate (no attitude above it) [A]", 1.0, 36000.0,
              unit="arcsec/s"),
    # Recognition (item 4).
    ParamSpec("recognition.max_objects", 10, "K: the brightest objects sent to recognition [A]", 3, 100),
    ParamSpec("recognition.rank_scatter_mag", 0.3, "sigma of the brightness-ranking scatter of stars [A]",
              0.0, 10.0, unit="mag"),
    ParamSpec("recognition.failure_at_3", 0.3, "p3: recognition failure with 3 catalogue stars [A]", 0.0, 1.0),
    ParamSpec("recognition.failure_scale_stars", 1.5, "n_s: p_geom = p3·exp(-(n - 3)/n_s) [A]", 0.01, 100.0),
    ParamSpec("recognition.false_object_failure", 0.01, "p_conf: failure per non-catalogue object among the K [A]",
              0.0, 1.0),
    # Accuracy (item 5).
    ParamSpec("centroid_error_arcsec", 9.5, "1-sigma centroid error of one star, per focal-plane axis, at rest "
              "[A: 3″ across the boresight in the median field]", 0.0, 3600.0, unit="arcsec"),
    ParamSpec("bias_fraction", 0.5, "share of the centroid variance that stays with a star while it is in the "
              "field [A]", 0.0, 1.0),
    # Protons (items 6, 7).
    ParamSpec("protons.trapped", "max", "AP8 model of the trapped protons: max (solar maximum) [A], min, off",
              choices=("max", "min", "off")),
    ParamSpec("protons.buffer_bytes", 4096, "video buffer (pixels above threshold) [T: Yamal units]", 64, 1 << 30,
              unit="B"),
    ParamSpec("protons.bytes_per_pixel", 4, "buffer bytes per pixel kept [A]", 1, 64, unit="B"),
    ParamSpec("protons.solar_event", "", "solar proton event: a named historical one, custom (the custom_* "
              "parameters), or empty: none", choices=SOLAR_EVENT_CHOICES),
    ParamSpec("protons.spectral_index", 2.0, "integral spectral index gamma of a named event: I(>45 MeV) = "
              "I(>=10 MeV)·4.5^-gamma [A]", 0.0, 6.0),
    ParamSpec("protons.decay_h", 12.0, "e-folding time of a solar event's decay [A]", 0.1, 720.0, unit="h"),
    ParamSpec("protons.custom_onset_utc", "2000-01-01T00:00:00Z", "custom event: start of its rise",
              constraints=_UTC),
    ParamSpec("protons.custom_peak_utc", "2000-01-01T12:00:00Z", "custom event: time of its peak",
              constraints=_UTC),
    ParamSpec("protons.custom_peak_pfu", 100.0, "custom event: peak I(>45 MeV)", 0.0, 1e6, unit="pfu"),
    ParamSpec("protons.access_min_l", 7.1, "solar protons reach where the McIlwain L is at least this [D: the "
              "Størmer cut-off of 45 MeV]", 1.0, 1000.0),
    # Exclusion (item 8).
    ParamSpec("exclusion.sun_deg", 30.0, "no attitude with the Sun within this of the boresight [A]", 0.0, 90.0,
              unit="deg"),
    ParamSpec("exclusion.moon_deg", 10.0, "no attitude with the Moon within this of the boresight [A]", 0.0, 90.0,
              unit="deg"),
    ParamSpec("exclusion.earth_limb_deg", 20.0, "no attitude with the Earth's limb within this of the boresight [A]",
              0.0, 90.0, unit="deg"),
    ParamSpec("exclusion.stray_light_at_edge", 1.0, "stray light over the sky background at an exclusion edge, "
              "falling as theta^-3 to nothing at twice the edge (a brighter background lowers the detection "
              "limit) [A]", 0.0, 1e6),
    # What is kept (item 9).
    ParamSpec("ideal", False, "true: every frame outside an outage gives the true attitude (no sky, noise, "
              "protons or exclusion; the frame timing stays)"),
    ParamSpec("outage_start_s", [-1.0], "start of each outage window after node start, an operator override "
              "(negative: none)", -1.0, 1e9, unit="s", max_length=MAX_OUTAGES),
    ParamSpec("outage_duration_s", [0.0], "duration of each outage window", 0.0, 1e9, unit="s",
              max_length=MAX_OUTAGES),
    # The input stream.
    ParamSpec("max_truth_gap_s", 5.0, "no frame is interpolated across a truth gap longer than this",
              0.001, 3600.0, unit="s"),
    ParamSpec("clock_jump_s", 1.0, "a truth stamp going back by more than this starts a new timeline "
              "(simulation or sensor restarted); less is a backward stamp and rejected", 0.001, 3600.0, unit="s"),
    ParamSpec("future_tolerance_s", 1.0, "truth stamps later than the node clock by more than this are rejected",
              0.001, 3600.0, unit="s"),
    ParamSpec("seed", 0, "seed of the tracker's draws (each keyed by its frame's time)", 0, 2**31 - 1,
              read_only=True),
)



#: Parameters of error_monitor_node.
MONITOR_PARAMS = INPUT_PARAMS + FRAME_PARAMS + MONITOR_INPUT_PARAMS + (
    replace(ORBIT_ALTITUDE, description="nominal orbit altitude (until /orbit/odometry arrives)"),
    replace(ORBIT_INCLINATION, description="nominal inclination (until /orbit/odometry arrives)"),
    ParamSpec("remove_oblateness", True, "report statistics with the closed-form oblateness model removed"),
    ParamSpec("sensor.oblateness_compensation", False, "the sensor already subtracts the oblateness model on "
              "board, so the monitor must not subtract it again (share it with the sensor in the /** section)"),
    ParamSpec("max_truth_gap_s", 2.0, "never interpolate truth across a gap longer than this", 0.001, 3600.0, unit="s"),
    ParamSpec("max_truth_wait_s", 10.0, "give a sensor sample up when no truth covers it after this long",
              0.01, 3600.0, unit="s"),
    ParamSpec("statistics_rate_hz", 1.0, "publication rate of /pmv/error_statistics", 0.001, 100.0, unit="Hz"),
    ParamSpec("roll_offset_arcmin", 0.0, "known constant roll offset removed before the statistics",
              -600.0, 600.0, unit="arcmin"),
    ParamSpec("pitch_offset_arcmin", 0.0, "known constant pitch offset removed before the statistics",
              -600.0, 600.0, unit="arcmin"),
    ParamSpec("clock_jump_s", 1.0, "a stamp going back by more than this is a clock jump (alignment reset)",
              0.001, 3600.0, unit="s"),
    ParamSpec("future_tolerance_s", 1.0, "stamps later than the node clock by more than this are rejected",
              0.001, 3600.0, unit="s"),
    ParamSpec("odometry_timeout_s", 5.0, "orbit data older than this is not used for the oblateness model",
              0.01, 3600.0, unit="s"),
)


def parse_epoch(iso_string: str) -> Epoch:
    """The run epoch from ``sim.epoch_utc``; ValueError naming the parameter if it is not a date-time in range."""
    try:
        return Epoch.from_utc(iso_string)
    except ValueError as error:
        raise ValueError(f"sim.epoch_utc: {error}") from None


def raan_at_epoch_rad(values: dict, epoch: Epoch) -> float:
    """The node at the epoch, rad: ``orbit.raan_deg``, or from ``orbit.ltan_h`` and the mean Sun at the run
    epoch (:func:`parse_epoch` of ``sim.epoch_utc``)."""
    ltan_h = values.get("orbit.ltan_h", -1.0)
    if ltan_h is None or ltan_h < 0.0:
        return math.radians(values["orbit.raan_deg"])
    if values["orbit.raan_deg"] != 0.0:
        raise ValueError("orbit.ltan_h and orbit.raan_deg both set the node: give one of them")
    return raan_from_local_time_of_node(ltan_h, epoch)


#: ``correction`` of :func:`build_models` when the table is still to be read from ``sensor.correction``.
READ_CORRECTION = object()


def build_models(values: dict, *, clock_epoch_s: float = 0.0, correction=READ_CORRECTION):
    """Orbit, attitude profile and instrument model from parameter values; ValueError if inconsistent.

    Args:
        values: sensor_node parameter values.
        clock_epoch_s: the node clock at the start of a real-time run, s (the orbit's epoch there;
            fast time starts at ``sim.start_time_s``).
        correction: the brightness-correction table already read (:func:`read_correction`; None: no
            correction), or :data:`READ_CORRECTION` to read what ``sensor.correction`` names now.
    """
    orbit, epoch = build_orbit(values, clock_epoch_s=clock_epoch_s)
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
    # The clock's zero: simulation time 0 in fast time, the node start in real time.
    clock_epoch = Epoch(epoch.julian_date_utc - orbit.epoch_s / SECONDS_PER_DAY)
    detector = build_detector(values, orbit, epoch, correction)
    mounting = Mounting.from_values(values)
    config = SensorConfig(
        ellipsoid=GRS80 if values["sensor.earth_model"] == "GRS80" else SPHERE,
        ideal_layer_height_m=values["sensor.layer_height_km"] * 1e3,
        oblateness_compensation=values["sensor.oblateness_compensation"],
        bright_body_exclusion_rad=math.radians(values["sensor.bright_body_exclusion_deg"]),
        epoch=clock_epoch,
        scan_start_nadir_rad=None if detector is not None else nominal_scan_start_nadir_rad(
            orbit.altitude_m, math.radians(values["sensor.scan_margin_deg"])),
        mounting_q_xyzw=None if mounting.aligned else mounting.q_body_to_sensor,
    )
    return orbit, profile, SensorModel(orbit, config, detector)


#: How far ahead of the run's start an element set's orbit is checked at start-up, s (SGP4 error codes).
ORBIT_CHECK_S = SECONDS_PER_DAY


def build_source_orbit(values: dict, epoch_s: float, check_span_s: float | None = None, *,
                       epoch: Epoch | None = None):
    """The orbit of ``orbit.source`` other than circular — a :class:`TleOrbit`, or for follow an empty
    :class:`FollowedOrbit` the node fills from odometry; ValueError in one line if not.

    ``check_span_s``: the span from the start checked for SGP4 error codes, s (None: :data:`ORBIT_CHECK_S`);
    ``epoch``: the run epoch if already parsed (:func:`parse_epoch`).
    """
    source = values["orbit.source"]
    if source == "follow":
        buffer = OrbitBuffer(values["orbit.extrapolation_s"], values["orbit.follow_timeout_s"])
        return FollowedOrbit(buffer, values["orbit.altitude_km"] * 1e3, epoch_s)
    epoch = parse_epoch(values["sim.epoch_utc"]) if epoch is None else epoch
    check_span_s = ORBIT_CHECK_S if check_span_s is None else check_span_s
    return TleOrbit(values["orbit.tle_line1"], values["orbit.tle_line2"], epoch,
                    epoch_s, check_span_s=check_span_s)


def nominal_altitude_m(values: dict) -> float:
    """The orbit's nominal altitude, m: ``orbit.altitude_km``, or an element set's mean one (orbit.source tle)."""
    if values.get("orbit.source", "circular") == "tle":
        altitude_m = element_set_altitude_m(values["orbit.tle_line1"], values["orbit.tle_line2"])
        # Before anything is built for it (the correction table's rig runs at this altitude): a decayed or
        # absurd element set is one line here, as TleOrbit would say it, not a failure of whatever came first.
        if not math.isfinite(altitude_m) or altitude_m < MIN_ALTITUDE_M:
            raise ValueError(f"orbit.tle_line2: the orbit is below the atmosphere: mean altitude "
                             f"{altitude_m / 1e3:.1f} km above the mean radius, at least {MIN_ALTITUDE_M / 1e3:g} km "
                             "is needed (mean motion)")
        if altitude_m > MAX_ALTITUDE_M:
            raise ValueError(f"orbit.tle_line2: mean altitude {altitude_m / 1e3:.0f} km is above the allowed "
                             f"{MAX_ALTITUDE_M / 1e3:g} km (mean motion)")
        return altitude_m
    return values["orbit.altitude_km"] * 1e3


def build_orbit(values: dict, *, clock_epoch_s: float = 0.0):
    """(the sensor's orbit, the run's epoch) from parameter values, as :func:`build_models` takes them; ValueError
    for a bad date or element set."""
    epoch = parse_epoch(values["sim.epoch_utc"])  # parsed whatever the detector: a bad date is refused now
    orbit = CircularOrbit(
        altitude_m=values["orbit.altitude_km"] * 1e3,
        inclination_rad=math.radians(values["orbit.inclination_deg"]),
        raan_rad=raan_at_epoch_rad(values, epoch),
        arg_latitude_at_epoch_rad=math.radians(values["orbit.u0_deg"]),
        epoch_s=values["sim.start_time_s"] if values["sim.fast_time"] else clock_epoch_s,
        j2_node_drift=values["orbit.j2_node_drift"],
    )
    if values["orbit.source"] != "circular":
        orbit = build_source_orbit(values, orbit.epoch_s, epoch=epoch)
    return orbit, epoch


def build_detector(values: dict, orbit: CircularOrbit, epoch: Epoch, correction=READ_CORRECTION):
    """The horizon detector the parameters ask for (None for the ideal one); ValueError if inconsistent.

    ``epoch``: the run epoch (:func:`parse_epoch`); ``correction``: as for :func:`build_models`.
    """
    if values["sensor.detector"] == "ideal":
        return None
    # The clock reads orbit.epoch_s at the start of the run (0 in fast time, the node start
    # in real time); anchor season and Earth rotation there exactly. (Stepping the epoch back
    # by a real-time clock of ≈ 1.8e9 s would let the GRS80 and GMST rates drift apart by ≈ 0.9°.)
    zero_s = orbit.epoch_s
    day_at_clock_zero = (float(epoch.day_of_year(0.0)) - zero_s / SECONDS_PER_DAY) % YEAR_DAYS
    rotation_at_clock_zero = float(epoch.earth_rotation_angle(0.0)) - EARTH_ROTATION_RATE_RAD_S * zero_s
    environment = EnvironmentParameters(
        climatology_enabled=values["environment.climatology"],
        climatology_sampling=values["environment.climatology_sampling"],
        weather_enabled=values["environment.weather"],
        height_variation_enabled=values["environment.height_variation"],
        relative_variability=values["environment.relative_variability"],
        correlation_radius_m=values["environment.correlation_radius_km"] * 1e3,
        synoptic_fraction=values["environment.synoptic_fraction"],
        synoptic_zone_m=values["environment.synoptic_zone_km"] * 1e3,
        height_correlation_radius_m=values["environment.height_correlation_radius_km"] * 1e3,
        time_scale_s=values["environment.time_scale_h"] * 3600.0,
        epoch_day_of_year=day_at_clock_zero,
        seed=values["seed"],
        # The fields on UTC (physics.md §3.2 item 6): seconds since J2000 when the clock reads 0.
        field_time_origin_s=float(epoch.seconds_since_j2000()) - zero_s,
    )
    radiance = RadianceConfig(
        source=values["radiance.source"],
        disc_radiance_ru=values["radiance.disc_ru"],
        window_height_m=values["radiance.window_height_km"] * 1e3,
        environment=environment,
        earth_rotation_at_epoch_rad=rotation_at_clock_zero % (2.0 * math.pi),
    )
    correction = read_correction(values) if correction is READ_CORRECTION else correction
    return ChainDetector(orbit.altitude_m, radiance, correction,
                         scan_margin_rad=math.radians(values["sensor.scan_margin_deg"]))


def read_correction(values: dict):
    """The brightness-correction table ``sensor.correction`` names (a file is read here); ValueError naming it.

    A node calls this once, at start-up, and keeps the table for every
    later :func:`build_models` (``sensor.correction`` and the orbit are
    read-only): no later parameter change, and so nothing a peer on the
    network sends, makes the node read a file.
    """
    altitude_m = nominal_altitude_m(values)
    try:
        return load_correction(values["sensor.correction"], altitude_m)
    except ValueError as error:
        raise ValueError(f"sensor.correction: {error}") from None


#: Parameters of attitude_controller_node (the closed loop's plant and controller).
CONTROLLER_PARAMS = controller_params(INPUT_PARAMS, ORBIT_ALTITUDE, MONITOR_INPUT_PARAMS[0])

#: Every node's parameters by node name (params files are keyed by it).
NODE_PARAMS = {"sensor_node": SENSOR_PARAMS, "star_tracker_node": STAR_TRACKER_PARAMS,
               "error_monitor_node": MONITOR_PARAMS, "attitude_controller_node": CONTROLLER_PARAMS}
