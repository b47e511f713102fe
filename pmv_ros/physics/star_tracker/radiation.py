"""Protons at the spacecraft: the AP8 trapped flux and the McIlwain L from the shipped grid, and solar events.

physics.md §6 items 6 and 7. ``tools/make_radiation_grid.py`` computes, with
the PyPI package ``aep8``, AP8's own coordinates on a geodetic latitude ×
longitude × altitude grid — the McIlwain L and B/B0 of each model's
magnetic field (AP8MIN's and AP8MAX's) — and each model's omnidirectional
integral proton flux above 45 and 100 MeV on an (L, ln B/B0) grid, and
ships them as ``pmv_ros/data/radiation_grid.bin``. Here L (as 1/L, smooth up
to the open field lines of the polar caps, where it is 0) and ln(B/B0) are
interpolated trilinearly at the spacecraft, then log10(J + 1 cm⁻² s⁻¹)
bilinearly in the flux table: the field is smooth where the flux is steep
(design/star_tracker_grid_error.py gives the error against aep8).

A solar proton event is a profile of the omnidirectional-equivalent
intensity I(>45 MeV) (pfu = cm⁻² s⁻¹ sr⁻¹): a linear rise from its onset
to its peak, then an exponential decay. Named historical events are presets
(:data:`SOLAR_EVENTS`). Access: where L ≥ the Størmer cut-off of 45 MeV
(L is beyond any cut-off on open field lines and at GEO).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .tables import data_path, read_table

RADIATION_FILE = "radiation_grid.bin"

#: The flux tables: (solar-cycle phase, threshold MeV) → column name.
FLUX_COLUMNS = {("min", 45): "ap8min_45mev", ("min", 100): "ap8min_100mev",
                ("max", 45): "ap8max_45mev", ("max", 100): "ap8max_100mev"}
#: The grid's fixed-point scales (int16): 1/L × 30000, ln(B/B0) × 5000 and log10(J + 1 cm⁻² s⁻¹) × 5000.
INVERSE_L_SCALE, LOG_FIELD_SCALE, LOG_FLUX_SCALE = 30000.0, 5000.0, 5000.0
SOLAR_PHASES = ("min", "max")


def _axis_position(values: np.ndarray, axis: np.ndarray):
    """(index of the cell's lower node, fraction within it) of ``values`` on an increasing ``axis`` (clamped)."""
    k = np.clip(np.searchsorted(axis, values) - 1, 0, axis.size - 2)
    fraction = np.clip((values - axis[k]) / (axis[k + 1] - axis[k]), 0.0, 1.0)
    return k, fraction


class RadiationGrid:
    """The shipped AP8 grid: trapped-proton flux above 45 and 100 MeV and the McIlwain L at geodetic points.

    Args:
        path: the grid file (default: the shipped one).
    """

    def __init__(self, path=None):
        path = data_path(RADIATION_FILE) if path is None else path
        self.provenance, columns = read_table(path, "radiation grid")
        try:
            self.latitude_deg = np.asarray(columns["latitude_deg"], float)
            self.longitude_deg = np.asarray(columns["longitude_deg"], float)
            self.altitude_km = np.asarray(columns["altitude_km"], float)
            self.shell_l = np.asarray(columns["shell_l"], float)
            self.log_field_ratio = np.asarray(columns["log_field_ratio"], float)
            grid_shape = (self.altitude_km.size, self.latitude_deg.size, self.longitude_deg.size)
            #: (phase) → (altitude, latitude, longitude, 2): 1/L and ln(B/B0).
            self._fields = {phase: np.stack([np.asarray(columns[f"{phase}_inverse_l"], float) / INVERSE_L_SCALE,
                                             np.asarray(columns[f"{phase}_log_field_ratio"], float) / LOG_FIELD_SCALE],
                                            axis=-1) for phase in SOLAR_PHASES}
            #: (phase) → (L, ln B/B0, 2): log10(J + 1) above 45 and 100 MeV.
            self._flux = {phase: np.stack([np.asarray(columns[FLUX_COLUMNS[(phase, 45)]], float),
                                           np.asarray(columns[FLUX_COLUMNS[(phase, 100)]], float)], axis=-1)
                          / LOG_FLUX_SCALE for phase in SOLAR_PHASES}
            table_shape = (self.shell_l.size, self.log_field_ratio.size)
            if min(grid_shape + table_shape) < 2 or any(f.shape[:3] != grid_shape for f in self._fields.values()) \
                    or any(f.shape[:2] != table_shape for f in self._flux.values()):
                raise KeyError
        except KeyError:
            raise ValueError(f"radiation grid {path} is corrupt: its columns do not form the grid") from None
        self._lat0, self._dlat = self.latitude_deg[0], self.latitude_deg[1] - self.latitude_deg[0]
        self._lon0, self._dlon = self.longitude_deg[0], self.longitude_deg[1] - self.longitude_deg[0]

    def field(self, latitude_rad, longitude_rad, altitude_m, solar: str = "max"):
        """(1/L, ln(B/B0)) of AP8's ``solar`` field model at geodetic points ``(N,)`` each (trilinear)."""
        lat = np.degrees(np.atleast_1d(np.asarray(latitude_rad, float)))
        lon = np.mod(np.degrees(np.atleast_1d(np.asarray(longitude_rad, float))) - self._lon0, 360.0)
        alt = np.atleast_1d(np.asarray(altitude_m, float)) / 1e3
        grid = self._fields[solar]
        n_lat, n_lon = grid.shape[1:3]
        fi = np.clip((lat - self._lat0) / self._dlat, 0.0, n_lat - 1.000001)
        fj = np.clip(lon / self._dlon, 0.0, n_lon - 1.000001)
        k, fk = _axis_position(alt, self.altitude_km)
        i, j = fi.astype(np.int64), fj.astype(np.int64)
        wi, wj, wk = (fi - i)[:, None], (fj - j)[:, None], fk[:, None]
        result = 0.0
        for dk, weight in ((0, 1.0 - wk), (1, wk)):
            plane = (grid[k + dk, i, j] * (1.0 - wj) + grid[k + dk, i, j + 1] * wj) * (1.0 - wi) \
                + (grid[k + dk, i + 1, j] * (1.0 - wj) + grid[k + dk, i + 1, j + 1] * wj) * wi
            result = result + plane * weight
        return result[:, 0], result[:, 1]

    def flux(self, inverse_l, log_field_ratio, solar: str = "max"):
        """AP8 ``solar`` J(>45 MeV), J(>100 MeV) at (1/L, ln B/B0), cm⁻² s⁻¹ ``(N,)`` each (bilinear in log10(J + 1);
        0 off the table: AP8 has no such protons there)."""
        inverse_l = np.asarray(inverse_l, float)
        with np.errstate(divide="ignore"):
            shell = np.where(inverse_l > 0.0, 1.0 / np.maximum(inverse_l, 1e-300), np.inf)
        log_field = np.asarray(log_field_ratio, float)
        table = self._flux[solar]
        k, fk = _axis_position(shell, self.shell_l)
        m, fm = _axis_position(log_field, self.log_field_ratio)
        fk, fm = fk[:, None], fm[:, None]
        value = (table[k, m] * (1.0 - fm) + table[k, m + 1] * fm) * (1.0 - fk) \
            + (table[k + 1, m] * (1.0 - fm) + table[k + 1, m + 1] * fm) * fk
        inside = (shell >= self.shell_l[0]) & (shell <= self.shell_l[-1]) & (log_field <= self.log_field_ratio[-1])
        flux = np.where(inside[:, None], np.maximum(10.0 ** value - 1.0, 0.0), 0.0)
        return flux[:, 0], flux[:, 1]

    def environment(self, latitude_rad, longitude_rad, altitude_m, solar: str = "max"):
        """(J(>45 MeV), J(>100 MeV), McIlwain L) at geodetic points, ``(N,)`` each.

        Args:
            latitude_rad, longitude_rad: geodetic latitude and longitude, rad, ``(N,)``.
            altitude_m: height above the WGS84/GRS80 ellipsoid, m, ``(N,)``; above the grid the top level is used.
            solar: AP8 ``"min"`` or ``"max"`` (the flux; L is AP8MAX's field's).

        Returns:
            omnidirectional integral fluxes, cm⁻² s⁻¹, and L (``inf`` on open field lines).
        """
        inverse_l, log_field = self.field(latitude_rad, longitude_rad, altitude_m, solar)
        flux45, flux100 = self.flux(inverse_l, log_field, solar)
        if solar != "max":
            inverse_l, _ = self.field(latitude_rad, longitude_rad, altitude_m, "max")
        with np.errstate(divide="ignore"):
            shell = np.where(inverse_l > 0.0, 1.0 / np.maximum(inverse_l, 1e-300), np.inf)
        return flux45, flux100, shell


@dataclass(frozen=True)
class SolarEvent:
    """A solar proton event: I(>45 MeV) rising linearly from the onset to the peak, then decaying exponentially.

    Args:
        onset_s: start of the rise, s since J2000 (UTC, 86400 s a day).
        peak_s: time of the peak, s since J2000 (≥ onset).
        peak_pfu: I(>45 MeV) at the peak, cm⁻² s⁻¹ sr⁻¹.
        decay_s: e-folding time of the decay, s.
    """

    onset_s: float
    peak_s: float
    peak_pfu: float
    decay_s: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.onset_s) and math.isfinite(self.peak_s) and self.peak_s >= self.onset_s):
            raise ValueError(f"solar event peak {self.peak_s} s must be at or after its onset {self.onset_s} s")
        if not (0.0 <= self.peak_pfu <= 1e6):
            raise ValueError(f"solar event peak {self.peak_pfu} pfu is outside the allowed range 0 … 1e6 pfu")
        if not (60.0 <= self.decay_s <= 30 * 86400.0):
            raise ValueError(f"solar event decay {self.decay_s} s is outside the allowed range 60 … 2592000 s")

    def intensity_pfu(self, t_j2000_s) -> np.ndarray:
        """I(>45 MeV) at UTC seconds since J2000 ``(N,)``, pfu."""
        t = np.asarray(t_j2000_s, float)
        rise = self.peak_s - self.onset_s
        rising = np.clip((t - self.onset_s) / rise, 0.0, 1.0) if rise > 0.0 else (t >= self.onset_s).astype(float)
        decaying = np.exp(-np.maximum(t - self.peak_s, 0.0) / self.decay_s)
        return self.peak_pfu * np.where(t < self.peak_s, rising, decaying)


#: Named historical events (NOAA SWPC "Solar Proton Events Affecting the Earth Environment": start and maximum
#: of the ≥ 10 MeV flux, UTC, and its peak in pfu [X: the list as published, to be checked against it]).
#: :func:`solar_event` scales the ≥ 10 MeV peak to 45 MeV with the event spectrum's integral index.
SOLAR_EVENTS = {
    "1989-10-19": ("1989-10-19T13:05:00Z", "1989-10-20T16:00:00Z", 40000.0),
    "2000-07-14": ("2000-07-14T10:45:00Z", "2000-07-15T12:30:00Z", 24000.0),
    "2000-11-08": ("2000-11-08T23:50:00Z", "2000-11-09T15:55:00Z", 14800.0),
    "2003-10-28": ("2003-10-28T12:15:00Z", "2003-10-29T06:15:00Z", 29500.0),
}
