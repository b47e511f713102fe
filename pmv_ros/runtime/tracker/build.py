"""The star tracker built from star_tracker_node's parameter values (the table:
:data:`pmv_ros.runtime.common.assembly.STAR_TRACKER_PARAMS`).

The orbit and the run's epoch are the sensor's own parameters (the same
specs, shared in a preset's ``/**`` section), so the tracker flies the orbit
the sensor flies: its circular orbit, its element set's SGP4, or — with
``orbit.source: follow`` — the user's ``orbit/odometry``, which the runtime
takes as the sensor does.
"""

from __future__ import annotations

import math
from functools import lru_cache

from ...physics.constants import ARCSEC_RAD, SECONDS_PER_DAY
from ...physics.orbit.ephemeris import Epoch, julian_date_from_utc
from ...physics.orbit.two_body import CircularOrbit
from ...physics.star_tracker import (SOLAR_EVENTS, RadiationGrid, Sky, SolarEvent, StarTracker, TrackerParameters,
                                     optimal_exposure_s)
from ..common.assembly import build_source_orbit, parse_epoch, raan_at_epoch_rad

def clock_epoch_s(values: dict, start_s: float) -> float:
    """The clock reading at which the orbit is at its epoch elements and UTC is ``sim.epoch_utc``, s: as the
    sensor's (``sim.start_time_s`` in fast time, the node's start otherwise)."""
    return values["sim.start_time_s"] if values["sim.fast_time"] else float(start_s)


def tracker_orbit(values: dict, epoch_s: float, epoch: Epoch):
    """The orbit the tracker flies, the sensor's: circular from the ``orbit.*`` elements, the element set's SGP4
    (orbit.source tle), or the user's orbit/odometry (follow: an orbit the runtime fills); ValueError in one line."""
    if values["orbit.source"] != "circular":
        return build_source_orbit(values, epoch_s, epoch=epoch)
    return CircularOrbit(altitude_m=values["orbit.altitude_km"] * 1e3,
                         inclination_rad=math.radians(values["orbit.inclination_deg"]),
                         raan_rad=raan_at_epoch_rad(values, epoch),
                         arg_latitude_at_epoch_rad=math.radians(values["orbit.u0_deg"]),
                         epoch_s=epoch_s, j2_node_drift=values["orbit.j2_node_drift"])


def solar_event(values: dict) -> SolarEvent | None:
    """The solar proton event ``protons.solar_event`` names (None: none); ValueError in one line."""
    name = values["protons.solar_event"]
    if not name:
        return None
    decay_s = values["protons.decay_h"] * 3600.0
    if name == "custom":
        onset, peak, peak_pfu = (values["protons.custom_onset_utc"], values["protons.custom_peak_utc"],
                                 values["protons.custom_peak_pfu"])
    else:
        onset, peak, peak_10mev_pfu = SOLAR_EVENTS[name]
        peak_pfu = peak_10mev_pfu * 4.5 ** -values["protons.spectral_index"]

    def seconds(text, parameter):
        try:
            return (julian_date_from_utc(text) - 2451545.0) * SECONDS_PER_DAY
        except ValueError as error:
            raise ValueError(f"{parameter}: {error}") from None

    onset_s = seconds(onset, "protons.custom_onset_utc")
    peak_s = seconds(peak, "protons.custom_peak_utc")
    if peak_s < onset_s:
        raise ValueError(f"protons.custom_peak_utc {peak} is before protons.custom_onset_utc {onset}")
    return SolarEvent(onset_s, peak_s, peak_pfu, decay_s)


def exposure_s(values: dict, mean_motion_rad_s: float) -> float:
    """``exposure_s``, or its default: the optimum at the orbital rate, at most the frame period, s."""
    if values["exposure_s"] > 0.0:
        if values["exposure_s"] > values["frame_period_s"]:
            raise ValueError(f"exposure_s = {values['exposure_s']:g} s is longer than frame_period_s = "
                             f"{values['frame_period_s']:g} s: a frame cannot start before the last one ends")
        return values["exposure_s"]
    return min(optimal_exposure_s(mean_motion_rad_s), values["frame_period_s"])


def tracker_parameters(values: dict, start_s: float, mean_motion_rad_s: float) -> TrackerParameters:
    """The model's configuration from parameter values; ValueError in one line if inconsistent.

    ``start_s``: the node clock at start (the outage windows count from it), s.
    """
    starts, durations = list(values["outage_start_s"]), list(values["outage_duration_s"])
    if len(starts) != len(durations):
        raise ValueError(f"outage_start_s has {len(starts)} entries but outage_duration_s has {len(durations)}")
    boresight = tuple(values["boresight_body"])
    if len(boresight) != 3 or math.hypot(*boresight) < 1e-6:
        raise ValueError(f"boresight_body = {list(boresight)} must be three numbers, not all zero")
    if values["sky_stars"] < values["catalogue_stars"]:
        raise ValueError(f"sky_stars = {values['sky_stars']} is fewer than catalogue_stars = "
                         f"{values['catalogue_stars']}: the catalogue is the brightest of the sky")
    return TrackerParameters(
        exposure_s=exposure_s(values, mean_motion_rad_s), frame_period_s=values["frame_period_s"],
        field_width_rad=math.radians(values["field_of_view_deg"]),
        catalogue_stars=values["catalogue_stars"], sky_stars=values["sky_stars"],
        detection_margin_mag=values["detection_margin_mag"],
        max_objects=values["recognition.max_objects"], rank_scatter_mag=values["recognition.rank_scatter_mag"],
        geometry_failure_3=values["recognition.failure_at_3"],
        geometry_failure_scale=values["recognition.failure_scale_stars"],
        false_object_failure=values["recognition.false_object_failure"],
        centroid_error_rad=values["centroid_error_arcsec"] * ARCSEC_RAD, bias_fraction=values["bias_fraction"],
        max_rate_rad_s=values["max_rate_arcsec_s"] * ARCSEC_RAD,
        trapped=values["protons.trapped"], solar_event=solar_event(values),
        access_min_l=values["protons.access_min_l"],
        buffer_bytes=values["protons.buffer_bytes"], bytes_per_pixel=values["protons.bytes_per_pixel"],
        sun_exclusion_rad=math.radians(values["exclusion.sun_deg"]),
        moon_exclusion_rad=math.radians(values["exclusion.moon_deg"]),
        earth_limb_exclusion_rad=math.radians(values["exclusion.earth_limb_deg"]),
        stray_light_at_edge=values["exclusion.stray_light_at_edge"],
        boresight_body=boresight,
        outages=tuple((start_s + s, start_s + s + d) for s, d in zip(starts, durations) if s >= 0.0 and d > 0.0),
        ideal=values["ideal"])


#: The date the sky is moved to is the run's, rounded to a tenth of a Julian year: the stars then move by at most
#: 2.5″ of precession (and ≈ 1″ of proper motion for all but a few), a quarter of one star's centroid error, and
#: the runs of a campaign share a few skies.
SKY_DATE_STEP_DAYS = 36.525


@lru_cache(maxsize=4)
def shipped_sky(julian_date_tt: float) -> Sky:
    """The shipped sky at a date (kept: the runs of one process share it)."""
    return Sky(julian_date_tt)


@lru_cache(maxsize=1)
def shipped_radiation() -> RadiationGrid:
    """The shipped radiation grid (kept: the runs of one process share it)."""
    return RadiationGrid()


class TrackerTables:
    """The sky and the radiation grid of a run, loaded once (a parameter change never reads a file)."""

    def __init__(self, julian_date_tt: float):
        step = SKY_DATE_STEP_DAYS
        self.sky = shipped_sky(round(julian_date_tt / step) * step)
        self._radiation = None

    @property
    def radiation(self) -> RadiationGrid:
        """The radiation grid (read the first time a model needs it)."""
        if self._radiation is None:
            self._radiation = shipped_radiation()
        return self._radiation


def build_tracker(values: dict, start_s: float,
                  tables: TrackerTables | None = None) -> tuple[StarTracker, TrackerTables | None]:
    """The star tracker from parameter values, and the tables it uses; ValueError in one line if not.

    ``start_s``: the node clock at start, s; ``tables``: already loaded (None: load them, unless ideal).
    """
    epoch = parse_epoch(values["sim.epoch_utc"])
    zero_s = clock_epoch_s(values, start_s)
    orbit = tracker_orbit(values, zero_s, epoch)
    clock_epoch = Epoch(epoch.julian_date_utc - zero_s / SECONDS_PER_DAY)
    parameters = tracker_parameters(values, start_s, orbit.mean_motion_rad_s)
    ahead = values["orbit.source"] != "follow"
    if parameters.ideal:
        return StarTracker(parameters, orbit, clock_epoch, values["seed"], orbit_known_ahead=ahead), tables
    if tables is None:
        tables = TrackerTables(float(epoch.julian_date_tt(0.0)))
    needs_grid = parameters.trapped != "off" or parameters.solar_event is not None
    return StarTracker(parameters, orbit, clock_epoch, values["seed"], sky=tables.sky,
                       radiation=tables.radiation if needs_grid else None, orbit_known_ahead=ahead), tables
