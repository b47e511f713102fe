"""The whole instrument for given orbit positions and attitudes: chords → crossings → roll/pitch.

Stages, in the order the instrument runs them (style.md: the chain reads as
its physics reads):

1. geometry — per chord, the nadir angles where the line of sight grazes the
   hard Earth and the top of the CO₂ layer on the GRS80 ellipsoid
   (:mod:`pmv_ros.physics.geometry`);
2. detection — the horizon crossing each chord reports: the signal chain of
   physics.md §4 under the radiance environment, or an ideal detector that
   reports the geometric horizon of the emitting layer (``detector=None``);
3. validity — a chord whose half-plane has no horizon, whose scan found no
   crossing, or whose swept arc has the Sun or the Moon within the exclusion
   angle (:func:`pmv_ros.physics.instrument.bright_body.bright_body_in_chords`) reports no
   crossing (NaN) and says why (:class:`ChordStatus`);
4. pair angles — roll from the ±Y pair, pitch from the ±X pair
   (:func:`pmv_ros.physics.geometry.roll_pitch_from_horizon_angles`): a lost
   chord takes its own pair's angle with it (NaN), never the other one, and
   nothing is fabricated from three chords;
5. optional on-board oblateness compensation with the closed-form model
   (physics.md §2.1), off by default as flown.

True and sensed quantities are kept apart: ``true_*`` is what an ideal
sensor would read for the true attitude, ``sensed_*`` what this one reports.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from .. import chain
from ..attitude import quaternion_product, true_roll_pitch
from .bright_body import bright_body_in_chords
from ..constants import EARTH_MEAN_RADIUS_M, GRS80, Ellipsoid
from ..environment import EnvironmentParameters, RadianceEnvironment
from ..orbit.ephemeris import BODY_NAMES, Epoch
from ..geometry import CHORD_AZIMUTHS_RAD, chord_line_of_sight, roll_pitch_from_horizon_angles, tangent_nadir_angles
from .oblateness import closed_form_oblateness, sensor_axes_eci
from .track_grid import FIELD_GRID_FRACTION, HORIZON_POINT_SPEED_M_S, MAX_FIELD_GRID_S, grid_nodes, interpolate_in_time
from ..orbit.two_body import CircularOrbit, eci_to_ecef, geocentric_latitude_longitude
from ..radiance import CO2_TOP_HEIGHT_M


#: Default exclusion angle of the Sun or the Moon from a chord's swept arc, rad:
#: the IFOV half-width γ = 1.1° (physics.md §4) + the body's radius ≈ 0.27°
#: + a stray-light margin of ≈ 1.6° for the optics, rounded to 3°.
DEFAULT_BRIGHT_BODY_EXCLUSION_RAD = float(np.radians(3.0))

#: Default scan start beyond the CO₂ top + γ, rad (covers oblateness ≈ 0.5° at 500 km and attitude excursions).
DEFAULT_SCAN_MARGIN_RAD = float(np.radians(3.0))


class ChordStatus(enum.IntEnum):
    """Per-chord validity codes (0 is valid)."""

    VALID = 0
    NO_HORIZON = 1  #: the chord's half-plane has no horizon (large attitude excursion)
    NOT_DETECTED = 2  #: the signal chain found no crossing within the scan
    SUN_OR_MOON = 3  #: the Sun or the Moon within the exclusion angle of the chord's swept arc


@dataclass(frozen=True)
class SensorConfig:
    """Instrument configuration that is not the signal chain's.

    Args:
        ellipsoid: Earth figure (GRS80; ``SPHERE`` switches oblateness off).
        ideal_layer_height_m: with the ideal detector, the height whose
            geometric horizon is reported, m.
        oblateness_compensation: subtract the closed-form oblateness model
            on board (physics.md §2.1); off by default, as flown.
        bright_body_exclusion_rad: a chord is invalid (``SUN_OR_MOON``)
            while the Sun or the Moon, not hidden by the Earth, is within
            this angle of the arc its IFOV centre sweeps from the scan start
            to the horizon, rad (0 … π/4; 0 switches the check off). See
            :data:`DEFAULT_BRIGHT_BODY_EXCLUSION_RAD`.
        epoch: the UTC instant at time 0 of the clock that :meth:`SensorModel.sense`
            is given (required when the exclusion is on: it places the Sun and the Moon).
        scan_start_nadir_rad: scan start θ₀ of the bright-body arc, rad;
            None: the detector's, or the nominal one of the orbit
            (:func:`nominal_scan_start_nadir_rad`) for the ideal detector.
        mounting_q_xyzw: orientation of the sensor frame in the body frame
            (x, y, z, w); None: the sensor axes are the body axes. The
            instrument scans in its own frame, so it reads roll and pitch of
            the sensor frame: a misalignment shows as a constant offset.
    """

    ellipsoid: Ellipsoid = GRS80
    ideal_layer_height_m: float = 40e3
    oblateness_compensation: bool = False
    bright_body_exclusion_rad: float = 0.0
    epoch: Epoch | None = None
    scan_start_nadir_rad: float | None = None
    mounting_q_xyzw: tuple | None = None

    def __post_init__(self) -> None:
        if self.mounting_q_xyzw is not None:
            norm = math.sqrt(sum(float(c) ** 2 for c in self.mounting_q_xyzw))
            if len(self.mounting_q_xyzw) != 4 or not abs(norm - 1.0) < 1e-9:
                raise ValueError(f"mounting_q_xyzw = {self.mounting_q_xyzw} is not a unit quaternion (x, y, z, w)")
        if not (0.0 <= self.ideal_layer_height_m <= 100e3):
            raise ValueError(f"ideal_layer_height_m = {self.ideal_layer_height_m} is outside the allowed range 0 … 100000 m")
        exclusion = float(self.bright_body_exclusion_rad)
        if not (np.isfinite(exclusion) and 0.0 <= exclusion <= np.pi / 4):
            raise ValueError(f"bright_body_exclusion_rad = {self.bright_body_exclusion_rad} is outside the allowed "
                             f"range 0 … {np.pi / 4:.4f} rad")
        if exclusion > 0.0 and self.epoch is None:
            raise ValueError("bright_body_exclusion_rad > 0 needs the epoch (UTC at time 0) to place the Sun and Moon")
        if self.scan_start_nadir_rad is not None and not (0.0 < self.scan_start_nadir_rad < np.pi / 2):
            raise ValueError(f"scan_start_nadir_rad = {self.scan_start_nadir_rad} is outside the allowed range "
                             f"(0, {np.pi / 2:.4f}) rad")


@dataclass(frozen=True)
class SensorReading:
    """What the sensor reports for N samples (arrays; rad; chords +X, +Y, −X, −Y)."""

    t_s: np.ndarray  #: (N,) sample times, s
    argument_of_latitude_rad: np.ndarray  #: (N,)
    crossing_nadir_rad: np.ndarray  #: (4, N) brightness-corrected crossing angles (NaN if invalid)
    crossing_nadir_uncorrected_rad: np.ndarray  #: (4, N)
    line_of_sight_sensor: np.ndarray  #: (3, 4, N) unit vectors to the corrected crossings (NaN if invalid)
    chord_status: np.ndarray  #: (4, N) ChordStatus codes
    sensed_roll_rad: np.ndarray  #: (N,) brightness-corrected
    sensed_pitch_rad: np.ndarray  #: (N,)
    sensed_roll_uncorrected_rad: np.ndarray  #: (N,)
    sensed_pitch_uncorrected_rad: np.ndarray  #: (N,)
    true_roll_rad: np.ndarray  #: (N,) what an ideal sensor reads for the true attitude
    true_pitch_rad: np.ndarray  #: (N,)
    #: (4, N) index into :data:`~pmv_ros.physics.orbit.ephemeris.BODY_NAMES` of the body that blinds the chord, −1 for none
    blinding_body: np.ndarray | None = None

    @property
    def chord_valid(self) -> np.ndarray:
        """(4, N) bool: the chord reported a crossing."""
        return self.chord_status == ChordStatus.VALID


def nominal_scan_start_nadir_rad(altitude_m: float, scan_margin_rad: float = DEFAULT_SCAN_MARGIN_RAD,
                                 params: chain.ChainParameters = chain.DEFAULT_CHAIN_PARAMETERS) -> float:
    """Fixed scan start θ₀ of the instrument, rad: CO₂ top of the nominal orbit over the mean sphere + γ + margin.

    Args:
        altitude_m: nominal orbit altitude, m.
        scan_margin_rad: extra start beyond φ₃ + γ, rad (0 … 20°).
        params: chain parameters (γ).
    """
    if not (0.0 <= scan_margin_rad <= np.radians(20.0)):
        raise ValueError(f"scan_margin_rad = {scan_margin_rad} is outside the allowed range 0 … 0.349 rad")
    phi0, slope = chain.sphere_chord(altitude_m)
    return float(chain.scan_start_nadir_angle(phi0, slope, CO2_TOP_HEIGHT_M, params)) + scan_margin_rad


#: How the chain's per-chord codes map onto the sensor's chord status.
_CHAIN_STATUS = np.full(max(chain.DetectionStatus) + 1, ChordStatus.NOT_DETECTED, np.int8)
_CHAIN_STATUS[chain.DetectionStatus.OK] = ChordStatus.VALID
_CHAIN_STATUS[chain.DetectionStatus.INVALID_INPUT] = ChordStatus.NO_HORIZON
_CHAIN_STATUS[chain.DetectionStatus.SCAN_STARTED_IN_ATMOSPHERE] = ChordStatus.NO_HORIZON


@dataclass(frozen=True)
class RadianceConfig:
    """Where the horizon radiance seen by each chord comes from.

    Args:
        source: ``"uniform"`` — the same disc radiance and window height on
            every chord (physics.md §3.1 Model A with B(1) = B(2)); or
            ``"environment"`` — :class:`~pmv_ros.physics.environment.RadianceEnvironment`
            sampled on the rotating Earth at each chord's horizon point: the
            window-layer height, and the radiance level B_m — climatology times
            weather — that scales the chord's whole profile (physics.md §3.2
            item 3). With ``environment.climatology_sampling = "line_of_sight"``
            the climatology is also taken where the lines of sight at the inward
            angles :data:`~pmv_ros.physics.chain.DISC_SAMPLE_INWARD_RAD` hit the
            ground (≈ 440, 830 and 1400 km inside the horizon at 835 km), and the
            chain interpolates the disc through those samples.
        disc_radiance_ru: uniform source: B_m, r.u.
        window_height_m: uniform source: h_w, m.
        environment: parameters of the environment source.
        earth_rotation_at_epoch_rad: Greenwich angle at simulation time 0, rad.
        field_grid_s: spacing of the coarse time grid on which the environment
            is evaluated when samples are denser, s (0.1 … 60); None: a fraction
            (:data:`FIELD_GRID_FRACTION`) of the time a horizon point takes to
            cross the smallest scale of a field (its correlation radius, or its
            shortest wavelength: 1600 km for the synoptic band of 2000 km zones,
            300 km for the weather's background, 100 km for the layer height),
            at most :data:`MAX_FIELD_GRID_S` — ≈ 30, 10 and 3.5 s; the band
            rides on the weather background's grid (:meth:`grid_spacing_s`).
            Between grid points the values are interpolated in time by cubic
            splines: a horizon point moves < 1 km between samples 0.1 s apart,
            against scales of hundreds of km.
    """

    source: str = "uniform"
    disc_radiance_ru: float = 2.4
    window_height_m: float = 40e3
    environment: EnvironmentParameters = EnvironmentParameters()
    earth_rotation_at_epoch_rad: float = 0.0
    field_grid_s: float | None = None

    def __post_init__(self) -> None:
        if self.source not in ("uniform", "environment"):
            raise ValueError(f"radiance source = {self.source!r} is not one of 'uniform', 'environment'")
        if not (0.0 < self.disc_radiance_ru <= 10.0):
            raise ValueError(f"disc_radiance_ru = {self.disc_radiance_ru} is outside the allowed range (0, 10] r.u.")
        if not (0.0 <= self.window_height_m <= 100e3):
            raise ValueError(f"window_height_m = {self.window_height_m} is outside the allowed range 0 … 100000 m")
        if self.field_grid_s is not None and not (0.1 <= self.field_grid_s <= 60.0):
            raise ValueError(f"field_grid_s = {self.field_grid_s} is outside the allowed range 0.1 … 60 s")

    def grid_spacing_s(self) -> tuple[float, float]:
        """The coarse grids' spacings, s: (the radiance — climatology and weather —, the window-layer height).

        See ``field_grid_s``. The radiance grid serves the weather's background (the finer of its two
        fields) and so the synoptic band too, whose shortest wavelength — its zone length ÷ 1.25, degree
        ℓ₀·1.25, ≥ 400 km — is longer than the background's (≤ 300 km).
        """
        if self.field_grid_s is not None:
            return (float(self.field_grid_s),) * 2
        p = self.environment
        height = p.correlation_radius_m if p.height_correlation_radius_m is None else p.height_correlation_radius_m

        def spacing(scale_m, fraction):
            return float(min(MAX_FIELD_GRID_S, fraction * scale_m / HORIZON_POINT_SPEED_M_S))

        return (min(spacing(p.synoptic_zone_m / 1.25, FIELD_GRID_FRACTION["band"]),
                    spacing(min(p.correlation_radius_m, p.weather_min_wavelength_m), FIELD_GRID_FRACTION["weather"])),
                spacing(max(height, p.min_wavelength_m), FIELD_GRID_FRACTION["height"]))


class ChainDetector:
    """Detection by the signal chain of physics.md §4 (:func:`pmv_ros.physics.chain.sense_horizon_chords`).

    Per chord, the ellipsoid geometry gives the hard-Earth horizon φ₀ and the
    grazing angle of the CO₂ top, hence dh/dφ; the radiance comes from
    :class:`RadianceConfig`. The scan starts at a fixed instrument angle: the
    CO₂ top of the nominal orbit over the mean sphere, plus γ, plus a margin
    that covers oblateness (≈ 0.5° at 500 km) and attitude excursions.

    Args:
        altitude_m: nominal orbit altitude (for the scan start), m.
        radiance: the radiance source.
        correction: brightness-correction table F (None: no correction).
        params: chain parameters.
        scan_margin_rad: extra scan start beyond φ₃ + γ, rad.
    """

    def __init__(self, altitude_m: float, radiance: RadianceConfig | None = None, correction=None,
                 params: chain.ChainParameters = chain.DEFAULT_CHAIN_PARAMETERS,
                 scan_margin_rad: float = DEFAULT_SCAN_MARGIN_RAD):
        self.radiance = radiance or RadianceConfig()
        self.correction = correction
        self.params = params
        self.scan_start_rad = nominal_scan_start_nadir_rad(altitude_m, scan_margin_rad, params)
        self.environment = (RadianceEnvironment(self.radiance.environment)
                            if self.radiance.source == "environment" else None)
        self.grid_s, self.height_grid_s = self.radiance.grid_spacing_s()

    def prepare(self) -> None:
        """Pay the chain's one-off start now (:func:`pmv_ros.physics.chain.prepare`), not at the first sample."""
        chain.prepare(self.params)

    def _chord_radiance(self, t_s, position_m, sensor_axes):
        """Horizon radiance B_m (r.u.), disc samples (r.u.) or None, and h_w (m) of each chord: ``(4, N)``, ``(4, N, 3)``.

        The horizon level (physics.md §3.2 item 3): the weather anomaly a and
        the climatology B_clim are taken once per chord and sample, at the
        chord's horizon point; B_m = B_clim·(1 + η·a), kept inside 1 … 4 r.u.,
        is the level of the chord's whole profile (a uniform disc: no samples,
        None). The window-layer height is taken at the horizon point too. With
        ``climatology_sampling = "line_of_sight"`` the climatology is taken at
        the disc samples as well, and every sample x carries the same weather
        factor: B(x) = B_clim(x)·(1 + η·a), each kept inside 1 … 4 r.u.

        Each field is evaluated at grid samples (one per grid spacing of the
        sample times, and the first and last) and interpolated in time to the
        other samples by a cubic spline: the climatology and the weather
        (background and synoptic band) every ``grid_s``, the window-layer
        height every ``height_grid_s`` (:mod:`.track_grid`); the horizon points
        are found once for both grids, and each grid's fields share one spline.
        When the samples are sparser than a grid: at every sample. The grids
        are tied to the fields' clock (UTC when the environment has a time
        origin), so runs of the same instants see the same nodes whatever their
        own clock reads.
        """
        t = np.atleast_1d(np.asarray(t_s, float))
        n = t.size
        shape = (4, n)
        if self.environment is None:
            return (np.full(shape, self.radiance.disc_radiance_ru), None,
                    np.full(shape, self.radiance.window_height_m))
        environment = self.environment
        parameters = environment.parameters
        # The climatology at the horizon point only (a level, physics.md §3.2 item 3), or also at the disc
        # samples along the line of sight.
        along_line_of_sight = parameters.climatology_sampling == "line_of_sight"
        band_field = environment.weather and environment.weather.band_field
        layer = environment.window_layer
        origin_s = parameters.field_time_origin_s
        nodes = {"radiance": grid_nodes(t, self.grid_s, origin_s)}
        if layer is not None:
            nodes["height"] = grid_nodes(t, self.height_grid_s, origin_s)
        # The horizon points once, at both grids' nodes in a row: (4 chords, nodes) each.
        every = np.concatenate(list(nodes.values()))
        horizon = [v.reshape(4, every.size) for v in self._ground_points(t[every], position_m[:, every],
                                                                          sensor_axes[:, :, every], False)]
        grid = nodes["radiance"]

        def where(name):
            """Latitude, longitude and time of the horizon points at a grid's nodes, flat (chord, node)."""
            columns = slice(0, grid.size) if name == "radiance" else slice(grid.size, every.size)
            return tuple(v[:, columns].ravel() for v in horizon)

        at_horizon = where("radiance")
        if along_line_of_sight:  # the horizon points lead the profile's points
            lat, _, t_points = self._ground_points(t[grid], position_m[:, grid], sensor_axes[:, :, grid], True)
        else:
            lat, _, t_points = at_horizon
        # The radiance grid's fields through one spline: (rows, 4 chords, nodes) → (rows, 4, N).
        climatology = environment.mean_radiance_ru(lat, t_points).reshape(-1, 4, grid.size)
        rows = [climatology]
        if environment.weather is not None:
            rows.append(environment.background_anomaly(*at_horizon).reshape(1, 4, grid.size))
            if band_field is not None:
                rows.append(band_field.evaluate(*at_horizon).reshape(1, 4, grid.size))
        values = interpolate_in_time(t, grid, np.concatenate(rows))
        parts = iter(values[climatology.shape[0]:])
        background = next(parts) if environment.weather is not None else None
        band = next(parts) if band_field is not None else None
        radiance = environment.radiance_from_parts(values[:climatology.shape[0]], background, band)  # (points, 4, N)
        if layer is None:
            window = np.full(shape, parameters.window_height_mean_m)
        else:  # the smooth Gaussian field is interpolated, then mapped to the uniform law at the samples
            gaussian = layer.gaussian_field(*where("height")).reshape(4, -1)
            window = layer.height_from_gaussian(interpolate_in_time(t, nodes["height"], gaussian))
        # A horizon level scales the whole profile: a uniform disc, no samples for the chain to interpolate.
        samples = radiance[1:].transpose(1, 2, 0) if along_line_of_sight else None
        return radiance[0], samples, window

    def _ground_points(self, t, position_m, sensor_axes, inner: bool):
        """Latitude, longitude (rad) and time of each chord's horizon point (and the disc sample points if ``inner``).

        Flat arrays ordered (point, chord, sample): the horizon point first,
        then the ground hit by the lines of sight at the inward sample angles.
        """
        radius = np.sqrt(np.einsum("in,in->n", position_m, position_m))
        up = position_m / radius
        # Chord directions ±X, ±Y of the sensor, made horizontal at the sub-satellite point.
        chords = np.concatenate([sensor_axes[:, :2], -sensor_axes[:, :2]], axis=1)
        horizontal = chords - np.einsum("ikn,in->kn", chords, up)[None] * up[:, None]
        horizontal /= np.sqrt(np.einsum("ikn,ikn->kn", horizontal, horizontal))
        # Spherical horizon: central angle acos(R/r) from the sub-satellite point; the ground the
        # lines of sight at the sample angles hit lies further in.
        angles = np.arccos(EARTH_MEAN_RADIUS_M / radius)[None]
        if inner:
            phi0, slope = chain.sphere_chord(radius - EARTH_MEAN_RADIUS_M)
            inward = np.asarray(chain.DISC_SAMPLE_INWARD_RAD)[:, None]
            distance = chain.chord_ground_distance(phi0 - inward, phi0, slope)  # (samples, N)
            angles = np.concatenate([angles, angles - distance / EARTH_MEAN_RADIUS_M])
        # (3, points, 4 chords, N)
        eci = np.cos(angles)[None, :, None, :] * up[:, None, None, :] + \
            np.sin(angles)[None, :, None, :] * horizontal[:, None, :, :]
        t_points = np.broadcast_to(t, eci.shape[1:]).reshape(-1)
        ecef = eci_to_ecef(eci.reshape(3, -1), t_points, self.radiance.earth_rotation_at_epoch_rad)
        lat, lon = geocentric_latitude_longitude(ecef)
        return lat, lon, t_points

    def __call__(self, t_s, horizon_nadir_rad, co2_top_nadir_rad, position_m, sensor_axes):
        """Corrected and uncorrected crossing nadir angles and statuses, each ``(4, N)``."""
        shape = horizon_nadir_rad.shape
        slope = chain.tangent_height_rate_from_layer(horizon_nadir_rad, co2_top_nadir_rad, CO2_TOP_HEIGHT_M)
        disc, samples, window = self._chord_radiance(t_s, position_m, sensor_axes)
        readings = chain.sense_horizon_chords(
            horizon_nadir_rad.ravel(), slope.ravel(), disc.ravel(), scan_start_nadir_rad=self.scan_start_rad,
            window_height_m=window.ravel(), disc_samples_ru=None if samples is None else samples.reshape(-1, len(chain.DISC_SAMPLE_INWARD_RAD)),
            correction=self.correction, params=self.params)
        return (readings.sensed_horizon_nadir_rad.reshape(shape),
                readings.sensed_horizon_nadir_uncorrected_rad.reshape(shape),
                _CHAIN_STATUS[readings.status].reshape(shape))


class SensorModel:
    """The PMV instrument on a given orbit.

    Args:
        orbit: the spacecraft orbit.
        config: instrument configuration.
        detector: callable ``detector(t_s, horizon_nadir_rad, co2_top_nadir_rad, position_m, sensor_axes)``
            returning ``(corrected (4, N), uncorrected (4, N), status (4, N))``
            crossing nadir angles; None for the ideal geometric detector.
    """

    def __init__(self, orbit: CircularOrbit, config: SensorConfig | None = None, detector=None):
        self.orbit = orbit
        self.config = config or SensorConfig()
        self.detector = detector
        if self.config.scan_start_nadir_rad is not None:
            self.scan_start_rad = self.config.scan_start_nadir_rad
        else:
            self.scan_start_rad = getattr(detector, "scan_start_rad", None) or nominal_scan_start_nadir_rad(
                orbit.altitude_m)

    def prepare(self) -> None:
        """Build what the first :meth:`sense` would build once (the detector's tables); nothing random is drawn."""
        if hasattr(self.detector, "prepare"):
            self.detector.prepare()

    def _ideal_detection(self, position, axes):
        horizon = tangent_nadir_angles(position, axes, self.config.ellipsoid, self.config.ideal_layer_height_m)
        status = np.where(np.isfinite(horizon), ChordStatus.VALID, ChordStatus.NO_HORIZON).astype(np.int8)
        return horizon, horizon, status

    def sense(self, t_s, q_orbital_to_body) -> SensorReading:
        """Run the instrument for N samples.

        Args:
            t_s: ``(N,)`` simulation times, s.
            q_orbital_to_body: ``(4, N)`` true body attitudes (x, y, z, w); the sensor frame is the
                body frame turned by the mounting (``SensorConfig.mounting_q_xyzw``).
        """
        t = np.atleast_1d(np.asarray(t_s, float))
        q = np.asarray(q_orbital_to_body, float).reshape(4, -1)
        q_sensor = q if self.config.mounting_q_xyzw is None else quaternion_product(q, self.config.mounting_q_xyzw)
        position, _ = self.orbit.state_eci(t)
        axes = sensor_axes_eci(self.orbit, t, q_sensor)
        horizon = None
        if self.detector is None:
            corrected, uncorrected, status = self._ideal_detection(position, axes)
        else:
            horizon = tangent_nadir_angles(position, axes, self.config.ellipsoid, 0.0)
            co2_top = tangent_nadir_angles(position, axes, self.config.ellipsoid, CO2_TOP_HEIGHT_M)
            corrected, uncorrected, status = self.detector(t, horizon, co2_top, position, axes)
            status = np.where(np.isfinite(horizon), status, ChordStatus.NO_HORIZON).astype(np.int8)
        blinding = np.full(status.shape, -1, np.int8)
        if self.config.bright_body_exclusion_rad > 0.0:
            if horizon is None:
                horizon = tangent_nadir_angles(position, axes, self.config.ellipsoid, 0.0)
            status, blinding = self._exclude_bright_bodies(t, q_sensor, horizon, status)
        valid = status == ChordStatus.VALID
        corrected = np.where(valid, corrected, np.nan)
        uncorrected = np.where(valid, uncorrected, np.nan)

        roll, pitch = roll_pitch_from_horizon_angles(corrected)
        roll_raw, pitch_raw = roll_pitch_from_horizon_angles(uncorrected)
        # The orbit where it is at each sample (constant altitude and inclination on the circular orbit).
        u, inclination, altitude = self.orbit.orbit_angles(t)
        if self.config.oblateness_compensation:
            _, model_roll, model_pitch = closed_form_oblateness(u, altitude, inclination, self.config.ellipsoid)
            roll, pitch = roll - model_roll, pitch - model_pitch
            roll_raw, pitch_raw = roll_raw - model_roll, pitch_raw - model_pitch
        true_roll, true_pitch = true_roll_pitch(q)
        return SensorReading(
            t_s=t,
            argument_of_latitude_rad=u,
            crossing_nadir_rad=corrected,
            crossing_nadir_uncorrected_rad=uncorrected,
            line_of_sight_sensor=chord_line_of_sight(corrected, CHORD_AZIMUTHS_RAD[:, None]),
            chord_status=status,
            sensed_roll_rad=roll,
            sensed_pitch_rad=pitch,
            sensed_roll_uncorrected_rad=roll_raw,
            sensed_pitch_uncorrected_rad=pitch_raw,
            true_roll_rad=np.atleast_1d(true_roll),
            true_pitch_rad=np.atleast_1d(true_pitch),
            blinding_body=blinding,
        )

    def _exclude_bright_bodies(self, t, q, horizon_nadir_rad, status):
        """Statuses with SUN_OR_MOON where a body is in a chord's field, and which body, each ``(4, N)``.

        The arc is the hard-Earth horizon to the scan start: the part of the
        scan that looks at space (a body below it is behind the Earth). A
        chord that has no horizon keeps NO_HORIZON — the body is not why.
        """
        check = bright_body_in_chords(self.orbit, t, q, self.config.epoch, horizon_nadir_rad,
                                      np.full_like(horizon_nadir_rad, self.scan_start_rad),
                                      self.config.bright_body_exclusion_rad, bodies=BODY_NAMES)
        blinded = check.blinded & (status != ChordStatus.NO_HORIZON)
        return (np.where(blinded, ChordStatus.SUN_OR_MOON, status).astype(np.int8),
                np.where(blinded, check.blinding_body, -1).astype(np.int8))
