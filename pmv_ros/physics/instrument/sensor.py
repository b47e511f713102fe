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
   angle (:mod:`pmv_ros.physics.instrument.bright_body`) reports no
   crossing (NaN) and says why (:class:`ChordStatus`);
4. pair angles — roll from the ±Y pair, pitch from the ±X pair
   (:func:`pmv_ros.physics.geometry.roll_pitch_from_horizon_angles`): a lost
   chord takes its own pair's angle with it (NaN), never the other one, and
   nothing is fabricated from three chords;
5. optional on-board oblateness compensation with the closed-form model
   (physics.md §2.1), off by default as flown.

What depends on the attitude and what does not are kept apart. The orbit,
its frame and the Sun and Moon along the track are evaluated once on a fixed
time grid (:mod:`.track`), the environment's fields along the horizon once
on a fixed (time, azimuth) grid (:mod:`.horizon_fields`); each sample does
only what its attitude changes, in one compiled pass (:mod:`.sensing`): a
block of one sample and of thousands run the same code, and a sample reads
the same in any of them.

True and sensed quantities are kept apart: ``true_*`` is what an ideal
sensor would read for the true attitude, ``sensed_*`` what this one reports.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .. import chain
from ..attitude import body_axes_in_orbital, true_roll_pitch
from ..constants import EARTH_MEAN_RADIUS_M, GRS80, Ellipsoid
from ..environment import EnvironmentParameters, RadianceEnvironment
from ..orbit.ephemeris import Epoch
from ..orbit.two_body import CircularOrbit
from ..radiance import CO2_TOP_HEIGHT_M
from . import sensing
from .horizon_fields import (FIELD_AZIMUTH_FRACTION, FIELD_TIME_FRACTION, HORIZON_POINT_SPEED_M_S, MAX_FIELD_GRID_S,
                             HorizonFields)
from .track import NO_STATES, TRACK_NODE_S, OrbitTrack


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
            raise ValueError(f"ideal_layer_height_m = {self.ideal_layer_height_m} is outside the allowed "
                             "range 0 … 100000 m")
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
    """What the sensor reports for N samples (arrays; rad; chords +X, +Y, −X, −Y).

    Every per-sample quantity is a view of ``table`` (N rows, the columns of
    :mod:`.sensing`), which a caller that wants rows (a node publishing) reads whole.
    """

    t_s: np.ndarray  #: (N,) sample times, s
    q_orbital_to_body: np.ndarray  #: (4, N) the true attitudes sensed at (x, y, z, w)
    table: np.ndarray  #: (N, sensing.COLUMNS) the samples' rows

    @property
    def argument_of_latitude_rad(self) -> np.ndarray:
        """(N,) of the orbit's state at each sample, 0 … 2π."""
        return self.table[:, sensing.ARGUMENT_OF_LATITUDE]

    @property
    def crossing_nadir_rad(self) -> np.ndarray:
        """(4, N) brightness-corrected crossing angles (NaN if invalid)."""
        return self.table[:, sensing.CORRECTED].T

    @property
    def crossing_nadir_uncorrected_rad(self) -> np.ndarray:
        """(4, N)."""
        return self.table[:, sensing.UNCORRECTED].T

    @property
    def line_of_sight_sensor(self) -> np.ndarray:
        """(3, 4, N) unit vectors to the corrected crossings (NaN if invalid)."""
        return self.table[:, sensing.LINE_OF_SIGHT].reshape(-1, 4, 3).transpose(2, 1, 0)

    @cached_property
    def chord_status(self) -> np.ndarray:
        """(4, N) ChordStatus codes."""
        return self.table[:, sensing.STATUS].T.astype(np.int8)

    @property
    def sensed_roll_rad(self) -> np.ndarray:
        """(N,) brightness-corrected."""
        return self.table[:, sensing.ROLL]

    @property
    def sensed_pitch_rad(self) -> np.ndarray:
        """(N,)."""
        return self.table[:, sensing.PITCH]

    @property
    def sensed_roll_uncorrected_rad(self) -> np.ndarray:
        """(N,)."""
        return self.table[:, sensing.ROLL_UNCORRECTED]

    @property
    def sensed_pitch_uncorrected_rad(self) -> np.ndarray:
        """(N,)."""
        return self.table[:, sensing.PITCH_UNCORRECTED]

    @cached_property
    def _true(self):
        roll, pitch = true_roll_pitch(self.q_orbital_to_body)
        return np.atleast_1d(roll), np.atleast_1d(pitch)

    @property
    def true_roll_rad(self) -> np.ndarray:
        """(N,) what an ideal sensor reads for the true attitude."""
        return self._true[0]

    @property
    def true_pitch_rad(self) -> np.ndarray:
        """(N,)."""
        return self._true[1]

    @cached_property
    def blinding_body(self) -> np.ndarray:
        """(4, N) index into :data:`~pmv_ros.physics.orbit.ephemeris.BODY_NAMES` of the body that blinds the
        chord, −1 for none."""
        return self.table[:, sensing.BLINDING].T.astype(np.int8)

    @property
    def position_eci_m(self) -> np.ndarray:
        """(3, N) the spacecraft's position at each sample (ECI, m)."""
        return self.table[:, sensing.POSITION].T

    @property
    def velocity_eci_m_s(self) -> np.ndarray:
        """(3, N) its velocity (ECI, m/s)."""
        return self.table[:, sensing.VELOCITY].T

    @property
    def horizon_radiance_ru(self) -> np.ndarray:
        """(4, N) the radiance level B_m of each chord's profile, r.u. (physics.md §3.2 item 3: the climatology
        and the weather at its horizon point); NaN where the chord has no horizon or the detector is ideal."""
        return self.table[:, sensing.HORIZON_RADIANCE].T

    @property
    def window_height_m(self) -> np.ndarray:
        """(4, N) the window-layer height h_w each chord sees, m (NaN as above)."""
        return self.table[:, sensing.WINDOW_HEIGHT].T

    @property
    def disc_samples_ru(self) -> np.ndarray:
        """(4, N, 3) the disc's radiance at the inward sample angles (climatology along the line of sight), r.u.;
        NaN where the disc is uniform (the climatology a level)."""
        return self.table[:, sensing.DISC_SAMPLES].reshape(-1, 4, 3).transpose(1, 0, 2)

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
        field_grid_s: spacing of the time grid on which the environment's random
            fields are kept along the horizon, s (0.1 … 60; :mod:`.horizon_fields`);
            None: a fraction (:data:`~.horizon_fields.FIELD_TIME_FRACTION`) of the
            time a horizon point takes to cross the smallest scale of a field (its
            correlation radius, or its shortest wavelength: 1600 km for the synoptic
            band of 2000 km zones, 300 km for the weather's background, 100 km for
            the layer height), at most :data:`~.horizon_fields.MAX_FIELD_GRID_S` —
            ≈ 4.2 s for the weather, 1.4 s for the layer height; the band rides on
            the weather background's grid (:meth:`grid_spacing_s`). The climatology
            is a formula, evaluated at each horizon point itself.
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
        """The field grids' time-node spacings, s: (the weather, the window-layer height).

        See ``field_grid_s``. The radiance grid serves the weather's background (the finer of its two
        fields) and so the synoptic band too, whose shortest wavelength — its zone length ÷ 1.25, degree
        ℓ₀·1.25, ≥ 400 km — is longer than the background's (≤ 300 km).
        """
        if self.field_grid_s is not None:
            return (float(self.field_grid_s),) * 2
        return tuple(float(min(MAX_FIELD_GRID_S, FIELD_TIME_FRACTION * scale / HORIZON_POINT_SPEED_M_S))
                     for scale in self.field_scales_m())

    def field_scales_m(self) -> tuple[float, float]:
        """The smallest scales of the gridded fields, m: (the weather — its background or its synoptic band —,
        the window-layer height)."""
        p = self.environment
        height = p.correlation_radius_m if p.height_correlation_radius_m is None else p.height_correlation_radius_m
        return (min(p.synoptic_zone_m / 1.25, p.correlation_radius_m, p.weather_min_wavelength_m),
                max(height, p.min_wavelength_m))

    def azimuth_nodes(self, altitude_m: float) -> tuple[int, int]:
        """Azimuth nodes around the horizon circle of an orbit ``altitude_m`` high: (weather, layer height), each
        a multiple of 4 spacing them ≤ :data:`~.horizon_fields.FIELD_AZIMUTH_FRACTION` of the field's scale."""
        circle_m = 2.0 * math.pi * EARTH_MEAN_RADIUS_M * math.sin(
            math.acos(EARTH_MEAN_RADIUS_M / (EARTH_MEAN_RADIUS_M + altitude_m)))
        return tuple(4 * math.ceil(circle_m / (4.0 * FIELD_AZIMUTH_FRACTION * scale))
                     for scale in self.field_scales_m())


class ChainDetector:
    """Detection by the signal chain of physics.md §4 (:func:`pmv_ros.physics.chain.sense_chord`).

    Per chord, the ellipsoid geometry gives the hard-Earth horizon φ₀ and the
    grazing angle of the CO₂ top, hence dh/dφ; the radiance comes from
    :class:`RadianceConfig`. The scan starts at a fixed instrument angle: the
    CO₂ top of the nominal orbit over the mean sphere, plus γ, plus a margin
    that covers oblateness (≈ 0.5° at 500 km) and attitude excursions.

    Args:
        altitude_m: nominal orbit altitude (for the scan start and the fields' azimuth grid), m.
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
        self.altitude_m = float(altitude_m)
        self.scan_start_rad = nominal_scan_start_nadir_rad(altitude_m, scan_margin_rad, params)
        self.environment = (RadianceEnvironment(self.radiance.environment)
                            if self.radiance.source == "environment" else None)
        self.grid_s, self.height_grid_s = self.radiance.grid_spacing_s()
        self.kit = chain.chain_kit(params, correction)

    def prepare(self) -> None:
        """Pay the chain's one-off start now (:func:`pmv_ros.physics.chain.prepare`), not at the first sample."""
        chain.prepare(self.params)

    def horizon_fields(self, track: OrbitTrack) -> HorizonFields | None:
        """The gridded fields along the horizon for a track (None without weather or layer height)."""
        environment = self.environment
        if environment is None or (environment.weather is None and environment.window_layer is None):
            return None
        return HorizonFields(environment, (self.grid_s, self.height_grid_s),
                             self.radiance.azimuth_nodes(self.altitude_m),
                             self.radiance.earth_rotation_at_epoch_rad, track)


#: The field grids of a sensor without gridded fields: both switched off, their tables empty.
_NO_GRID_PARAMS = np.array([1.0, 0.0, 4.0, 0.0] * 2)
_NO_GRIDS = (np.full(1, np.iinfo(np.int64).min, np.int64), np.full(1, np.nan)) * 2
#: Field nodes a call can report missing before it fills them and runs again.
_MISSES = 4096


class SensorModel:
    """The PMV instrument on a given orbit.

    Args:
        orbit: the spacecraft orbit.
        config: instrument configuration.
        detector: a :class:`ChainDetector`, or None for the ideal geometric detector.
    """

    def __init__(self, orbit: CircularOrbit, config: SensorConfig | None = None, detector: ChainDetector | None = None):
        self.orbit = orbit
        self.config = config = config or SensorConfig()
        self.detector = detector
        if config.scan_start_nadir_rad is not None:
            self.scan_start_rad = config.scan_start_nadir_rad
        else:
            self.scan_start_rad = getattr(detector, "scan_start_rad", None) or nominal_scan_start_nadir_rad(
                orbit.altitude_m)
        blinding = config.bright_body_exclusion_rad > 0.0
        #: The orbit, the Sun and the Moon along the track (nothing here depends on the attitude).
        self.track = OrbitTrack(orbit, config.epoch if blinding else None)
        self.fields = detector.horizon_fields(self.track) if detector is not None else None
        self._kit = detector.kit if detector is not None else chain.chain_kit()
        mounted = config.mounting_q_xyzw is not None
        self._mounting = np.ascontiguousarray(body_axes_in_orbital(np.asarray(config.mounting_q_xyzw, float))) \
            if mounted else np.eye(3)
        self._static = np.concatenate([self._config_vector(mounted), self._mounting.ravel(),
                                       _NO_GRID_PARAMS if self.fields is None else self.fields.params])
        self._misses = np.empty((_MISSES, 3), np.int64)
        self._need = np.empty(2, np.int64)  # the track nodes the kernel lacks
        floats, ints = sensing.scratch_sizes(self._kit.knots)
        self._scratch, self._int_scratch = np.empty(floats), np.empty(ints, np.int64)

    def _config_vector(self, mounted: bool) -> np.ndarray:
        config, detector = self.config, self.detector
        c = np.zeros(sensing.CONFIG_SIZE)
        c[sensing.A_M], c[sensing.B_M] = config.ellipsoid.a_m, config.ellipsoid.b_m
        c[sensing.IDEAL_HEIGHT_M] = config.ideal_layer_height_m
        c[sensing.CO2_TOP_M] = CO2_TOP_HEIGHT_M
        c[sensing.SCAN_START_RAD] = self.scan_start_rad
        c[sensing.EXCLUSION_RAD] = config.bright_body_exclusion_rad
        c[sensing.COMPENSATION] = config.oblateness_compensation
        c[sensing.MOUNTED] = mounted
        c[sensing.EARTH_RADIUS_M] = EARTH_MEAN_RADIUS_M
        if detector is not None:
            radiance, params = detector.radiance, detector.params
            c[sensing.CHAIN] = 1.0
            c[sensing.CO2_RADIANCE_RU], c[sensing.CO2_HEIGHT_M] = params.co2_radiance_ru, params.co2_top_height_m
            c[sensing.DISC_RU], c[sensing.WINDOW_M] = radiance.disc_radiance_ru, radiance.window_height_m
            if detector.environment is not None:
                e = detector.environment.parameters
                c[sensing.ENVIRONMENT] = 1.0
                c[sensing.CLIMATOLOGY] = e.climatology_enabled
                c[sensing.UNIFORM_RU] = e.uniform_radiance_ru
                c[sensing.EPOCH_DAY] = e.epoch_day_of_year
                c[sensing.ETA] = e.relative_variability
                layer = detector.environment.window_layer
                c[sensing.WINDOW_MEAN_M] = e.window_height_mean_m
                c[sensing.WINDOW_HALF_RANGE_M] = layer.half_range_m if layer is not None else 0.0
                c[sensing.ALONG_SIGHT] = e.climatology_sampling == "line_of_sight"
        return c

    def prepare(self) -> None:
        """Build what the first :meth:`sense` would build once (the detector's tables, the compiled kernels);
        nothing random is drawn and no sample is sensed."""
        if hasattr(self.detector, "prepare"):
            self.detector.prepare()
        self._run(np.empty(0), np.empty((0, 4)), np.empty((0, 6)), np.empty((0, sensing.COLUMNS)))

    def _run(self, t, attitude, states, table):
        nodes, track = self.track.kernel_inputs()
        grids = _NO_GRIDS if self.fields is None else self.fields.kernel_inputs()
        return sensing.sense_samples(t, attitude, states, nodes, track, self._static, *self._kit, *grids, table,
                                     self._misses, self._need, self._scratch, self._int_scratch)

    def sense(self, t_s, q_orbital_to_body) -> SensorReading:
        """Run the instrument for N samples.

        Args:
            t_s: ``(N,)`` simulation times, s.
            q_orbital_to_body: ``(4, N)`` true body attitudes (x, y, z, w); the sensor frame is the
                body frame turned by the mounting (``SensorConfig.mounting_q_xyzw``).

        Raises what the orbit raises where it has no state (an element set SGP4 cannot propagate, a
        followed orbit without odometry there).
        """
        t = np.asarray(t_s, float).reshape(-1)
        q = np.asarray(q_orbital_to_body, float).reshape(4, -1)
        return SensorReading(t, q, self.sense_rows(t, np.ascontiguousarray(q.T)))

    def sense_rows(self, t: np.ndarray, attitude: np.ndarray) -> np.ndarray:
        """:meth:`sense`'s table, ``(N, sensing.COLUMNS)``, for arguments already in the kernel's layout: ``t``
        ``(N,)`` float64, s; ``attitude`` ``(N, 4)`` C-contiguous float64 (x, y, z, w) — :meth:`sense` after
        its checks, and a following sensor, whose attitudes come as rows. Raises as :meth:`sense` does."""
        table = np.empty((t.size, sensing.COLUMNS))
        if t.size == 0:
            return table
        states = NO_STATES if self.track.model_orbit else self.track.states(t)
        fields = self.fields
        if fields is not None and not fields.current:
            fields.refresh()
        if self.track.has_errors:
            self.track.needs(math.floor(float(t.min()) / TRACK_NODE_S) - 1,
                             math.floor(float(t.max()) / TRACK_NODE_S) + 2)
        missing = self._run(t, attitude, states, table)
        first = 0  # the samples before are done
        while missing:
            if missing < 0:
                self.track.needs(int(self._need[0]), int(self._need[1]))
            else:
                fields.fill(self._misses, min(missing, self._misses.shape[0]), t, states)
                first += int(self._need[0])
                if missing > self._misses.shape[0]:
                    self._misses = np.empty((2 * missing, 3), np.int64)
            missing = self._run(t[first:], attitude[first:], states[first:], table[first:])
        return table
