"""The whole instrument for given orbit positions and attitudes: chords → crossings → roll/pitch.

Stages, in the order the instrument runs them (style.md: the chain reads as
its physics reads):

1. geometry — per chord, the nadir angles where the line of sight grazes the
   hard Earth and the top of the CO₂ layer on the GRS80 ellipsoid
   (:mod:`pmv_ros.core.geometry`);
2. detection — the horizon crossing each chord reports: the signal chain of
   physics.md §4 under the radiance environment, or an ideal detector that
   reports the geometric horizon of the emitting layer (``detector=None``);
3. pair angles — roll from the ±Y pair, pitch from the ±X pair
   (:func:`pmv_ros.core.geometry.roll_pitch_from_horizon_angles`);
4. optional on-board oblateness compensation with the closed-form model
   (physics.md §2.1), off by default as flown.

True and sensed quantities are kept apart: ``true_*`` is what an ideal
sensor would read for the true attitude, ``sensed_*`` what this one reports.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from .attitude import true_roll_pitch
from .constants import GRS80, Ellipsoid
from .geometry import CHORD_AZIMUTHS_RAD, chord_line_of_sight, roll_pitch_from_horizon_angles, tangent_nadir_angles
from .oblateness import closed_form_oblateness, sensor_axes_eci
from .orbit import CircularOrbit

#: Height of the top of the CO₂ layer, m (physics.md §3: ≈ 60 km).
CO2_LAYER_TOP_M = 60e3


class ChordStatus(enum.IntEnum):
    """Per-chord validity codes (0 is valid)."""

    VALID = 0
    NO_HORIZON = 1  #: the chord's half-plane has no horizon (large attitude excursion)
    NOT_DETECTED = 2  #: the signal chain found no crossing within the scan
    SUN_OR_MOON = 3  #: a bright body in the chord's field


@dataclass(frozen=True)
class SensorConfig:
    """Instrument configuration that is not the signal chain's.

    Args:
        ellipsoid: Earth figure (GRS80; ``SPHERE`` switches oblateness off).
        ideal_layer_height_m: with the ideal detector, the height whose
            geometric horizon is reported, m.
        oblateness_compensation: subtract the closed-form oblateness model
            on board (physics.md §2.1); off by default, as flown.
    """

    ellipsoid: Ellipsoid = GRS80
    ideal_layer_height_m: float = 40e3
    oblateness_compensation: bool = False

    def __post_init__(self) -> None:
        if not (0.0 <= self.ideal_layer_height_m <= 100e3):
            raise ValueError(f"ideal_layer_height_m = {self.ideal_layer_height_m} is outside the allowed range 0 … 100000 m")


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

    @property
    def chord_valid(self) -> np.ndarray:
        """(4, N) bool: the chord reported a crossing."""
        return self.chord_status == ChordStatus.VALID


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

    def _ideal_detection(self, position, axes):
        horizon = tangent_nadir_angles(position, axes, self.config.ellipsoid, self.config.ideal_layer_height_m)
        status = np.where(np.isfinite(horizon), ChordStatus.VALID, ChordStatus.NO_HORIZON).astype(np.int8)
        return horizon, horizon, status

    def sense(self, t_s, q_orbital_to_body) -> SensorReading:
        """Run the instrument for N samples.

        Args:
            t_s: ``(N,)`` simulation times, s.
            q_orbital_to_body: ``(4, N)`` true body attitudes (x, y, z, w).
        """
        t = np.atleast_1d(np.asarray(t_s, float))
        q = np.asarray(q_orbital_to_body, float).reshape(4, -1)
        position, _ = self.orbit.state_eci(t)
        axes = sensor_axes_eci(self.orbit, t, q)
        if self.detector is None:
            corrected, uncorrected, status = self._ideal_detection(position, axes)
        else:
            horizon = tangent_nadir_angles(position, axes, self.config.ellipsoid, 0.0)
            co2_top = tangent_nadir_angles(position, axes, self.config.ellipsoid, CO2_LAYER_TOP_M)
            corrected, uncorrected, status = self.detector(t, horizon, co2_top, position, axes)
            status = np.where(np.isfinite(horizon), status, ChordStatus.NO_HORIZON).astype(np.int8)
        valid = status == ChordStatus.VALID
        corrected = np.where(valid, corrected, np.nan)
        uncorrected = np.where(valid, uncorrected, np.nan)

        roll, pitch = roll_pitch_from_horizon_angles(corrected)
        roll_raw, pitch_raw = roll_pitch_from_horizon_angles(uncorrected)
        u = self.orbit.argument_of_latitude(t)
        if self.config.oblateness_compensation:
            _, model_roll, model_pitch = closed_form_oblateness(u, self.orbit.altitude_m, self.orbit.inclination_rad,
                                                                self.config.ellipsoid)
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
        )
