"""The signal chain's parameters (physics.md §1, §3, §4) and the reason code of a chord's reading."""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from ..radiance import (
    CO2_RADIANCE_RU,
    CO2_TOP_HEIGHT_M,
    LINEAR_RAMP,
    MAX_LAYER_HEIGHT_M,
    WINDOW_HEIGHT_M,
    RampShape,
)


class DetectionStatus(enum.IntEnum):
    """Reason code of one chord's reading (0 = good; otherwise the outputs are NaN)."""

    #: Both comparators fired; all outputs valid.
    OK = 0
    #: A per-chord input was NaN or outside its range (see :func:`sense_horizon_chords`).
    INVALID_INPUT = 1
    #: The field already saw the atmosphere at the scan start: the horizon lies outside the scan.
    SCAN_STARTED_IN_ATMOSPHERE = 2
    #: The output never exceeded J(1) within the scan (no horizon crossing found).
    FIRST_THRESHOLD_NOT_REACHED = 3
    #: J(1) was crossed but J(2) never was (the horizon too dark to measure Del).
    SECOND_THRESHOLD_NOT_REACHED = 4


@dataclass(frozen=True)
class ChainParameters:
    """Instrument and horizon parameters of the signal chain (physics.md §1, §3, §4). SI units.

    The detector time constant is not published. It was fitted so that
    Model A at 500 km reproduces the β column of the physics.md §4 table
    (tools/calibrate_chain.py; values and residuals in
    pmv_ros/data/chain_calibration.json): with the linear ramp,
    T_p = 1.5685 ms gives β = 23.50′, 32.20′, 37.26′, 13.77′ against the
    published 22.7′, 32′, 37.4′, 14.7′ (+3.5 %, +0.6 %, −0.4 %, −6.4 %;
    RMS 3.7 %). The ramp shape is not constrained by that table: a
    power-law ramp (1 − u)^p fits as well for any p in 0.25 … 4 (RMS
    3.55 … 4.1 %; the joint optimum, p ≈ 0.3, gains 0.1 %), so the simplest
    shape — linear in tangent height — is the default.

    Args:
        ifov_full_angle_rad: full angle 2γ of the instantaneous field of view (2.2°).
        scan_rate_rad_s: radial scan rate W (2.46 °/ms).
        time_step_s: simulation time step dt (0.01 ms).
        max_steps: number of scan steps (2000).
        detector_time_constant_s: T_p of the detector + electronics lag.
        threshold_1_ru, threshold_2_ru: comparator thresholds J(1), J(2) (0.33 J, 0.67 J).
        co2_radiance_ru: B_a of the CO₂ layer (0.3 J).
        co2_top_height_m: top of the CO₂ layer (60 km).
        window_height_m: nominal height h_w of the window emitting layer (40 km).
        ramp: shape of the window-region ramp.
    """

    ifov_full_angle_rad: float = math.radians(2.2)
    scan_rate_rad_s: float = math.radians(2.46) / 1e-3
    time_step_s: float = 1e-5
    max_steps: int = 2000
    # Fitted by tools/calibrate_chain.py (see the class docstring).
    detector_time_constant_s: float = 1.5685e-3
    threshold_1_ru: float = 0.33
    threshold_2_ru: float = 0.67
    co2_radiance_ru: float = CO2_RADIANCE_RU
    co2_top_height_m: float = CO2_TOP_HEIGHT_M
    window_height_m: float = WINDOW_HEIGHT_M
    ramp: RampShape = field(default=LINEAR_RAMP)

    def __post_init__(self) -> None:
        def check(name, low, high, unit="", scale=1.0):
            value = getattr(self, name)
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise ValueError(f"{name} must be a number, got {value!r}") from None
            if not (math.isfinite(number) and low < number * scale <= high):
                raise ValueError(f"{name} = {value!r} is outside the allowed range "
                                 f"({low / scale:g}, {high / scale:g}]{unit}")

        check("ifov_full_angle_rad", 0.0, math.radians(20.0), " rad")
        check("scan_rate_rad_s", 0.0, 1e4, " rad/s")
        check("time_step_s", 0.0, 1e-3, " s")
        check("detector_time_constant_s", 0.0, 1.0, " s")
        check("threshold_1_ru", 0.0, 100.0, " r.u.")
        check("threshold_2_ru", 0.0, 100.0, " r.u.")
        check("co2_top_height_m", 0.0, MAX_LAYER_HEIGHT_M, " m")
        if not (isinstance(self.max_steps, (int, np.integer)) and 10 <= self.max_steps <= 100000):
            raise ValueError(f"max_steps = {self.max_steps!r} is outside the allowed range 10 … 100000 (an integer)")
        if not self.threshold_1_ru < self.threshold_2_ru:
            raise ValueError(f"threshold_1_ru = {self.threshold_1_ru} must be below "
                             f"threshold_2_ru = {self.threshold_2_ru}")
        if not (math.isfinite(self.co2_radiance_ru) and 0.0 <= self.co2_radiance_ru < self.threshold_1_ru):
            raise ValueError(f"co2_radiance_ru = {self.co2_radiance_ru} is outside the allowed range "
                             f"[0, {self.threshold_1_ru}) r.u. (below the first threshold)")
        if not (math.isfinite(self.window_height_m) and 0.0 <= self.window_height_m <= MAX_LAYER_HEIGHT_M):
            raise ValueError(f"window_height_m = {self.window_height_m} is outside the allowed range "
                             f"[0, {MAX_LAYER_HEIGHT_M:g}] m")
        if not isinstance(self.ramp, RampShape):
            raise ValueError(f"ramp must be a RampShape, got {type(self.ramp).__name__}")

    @property
    def ifov_half_angle_rad(self) -> float:
        """γ, half the full angle of the field, rad."""
        return 0.5 * self.ifov_full_angle_rad

    @property
    def step_angle_rad(self) -> float:
        """Δ = W·dt, the scan angle of one time step, rad."""
        return self.scan_rate_rad_s * self.time_step_s

    @property
    def lag_decay_per_step(self) -> float:
        """r = exp(−dt/T_p), the lag's memory over one step."""
        return math.exp(-self.time_step_s / self.detector_time_constant_s)


DEFAULT_CHAIN_PARAMETERS = ChainParameters()
