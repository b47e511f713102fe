"""The brightness-correction table F(Del): made on the calibration rig, stored, loaded, applied.

physics.md §4, step 6: the instrument stores a curve POP = F(Del) and
corrects each chord's crossing angle by Gam′ = Gam − POP. The curve is
measured on a calibration rig — a uniform Earth simulator (Model A
conditions) — over the 1 … 4 r.u. range of horizon radiance. Here the rig
is simulated the same way (:func:`rig_correction_table`): for each rig
radiance B the chain gives Del(B) and Gam(B), and

    POP(B) = Gam(B) − (θ₀ − φ₀),

the crossing angle's excess over the geometric one of the hard-Earth horizon
φ₀. A corrected chord therefore reads θ₀ − Gam′ = φ₀ exactly under rig
conditions at the rig's altitude, whatever the radiance; anything else
(gradients, weather, a different emitting-layer height) leaves a residual —
the methodical error of physics.md §3.1.

Look-up is linear interpolation in Del, clamped to the end values outside
the table (what a stored curve does). Three ways to fly (physics.md §4):
the calibrated table (:func:`calibrated_correction_table`, shipped in
``pmv_ros/data/`` for the 500 km and 835 km reference orbits, simulated
for any other altitude), no table (``None``: Gam′ = Gam), or a table loaded
from a file (:meth:`CorrectionTable.from_csv`). The stored curve of
Meteor-M No.2-2 did not correct; its flight record implies an over-correcting
one, inferred as the working curve with a gain error, POP × s with 1 < s ≤ 2
(physics.md §3.2 item 1): :func:`scaled_correction_table`, shipped as
``meteor_m2_2`` (:func:`meteor_m2_2_table`).

File format: CSV, ``#`` comment lines allowed, a header row
``del_arcmin,pop_arcmin`` and one row per table point (arcmin, because
people write these files).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from ..chain import DEFAULT_CHAIN_PARAMETERS, scan_start_nadir_angle, sense_horizon_chords, sphere_chord
from ..constants import ARCMIN_RAD, EARTH_MEAN_RADIUS_M
from ..radiance import MAX_EARTH_RADIANCE_RU, MIN_EARTH_RADIANCE_RU
from ...storage.files import read_text_file

#: Rig radiances, r.u.: 1 … 4 in steps of 0.025 (121 points).
RIG_RADIANCES_RU = tuple(np.round(np.linspace(MIN_EARTH_RADIANCE_RU, MAX_EARTH_RADIANCE_RU, 121), 6))
#: Altitudes, km, whose rig tables ship in pmv_ros/data/ (the reference orbits of physics.md §2).
STORED_TABLE_ALTITUDES_KM = (500, 835)
#: Column names of a table file.
CSV_COLUMNS = ("del_arcmin", "pop_arcmin")


@dataclass(frozen=True, eq=False)
class CorrectionTable:
    """A stored brightness-correction curve POP = F(Del); call it with Del in rad to get POP in rad.

    Args:
        del_rad: table abscissae Del, rad, strictly increasing (at least 2).
        pop_rad: POP at those points, rad.
        source: where the table came from (for people and reports).
    """

    del_rad: np.ndarray
    pop_rad: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        d = np.array(self.del_rad, float, copy=True)
        p = np.array(self.pop_rad, float, copy=True)
        if d.ndim != 1 or d.shape != p.shape or d.size < 2:
            raise ValueError(f"a correction table needs at least 2 (Del, POP) pairs of equal length, "
                             f"got {d.size} and {p.size}")
        if not (np.all(np.isfinite(d)) and np.all(np.isfinite(p))):
            raise ValueError("correction table values must be finite numbers")
        if np.any(np.diff(d) <= 0.0):
            raise ValueError("correction table Del values must be strictly increasing")
        d.flags.writeable = False
        p.flags.writeable = False
        object.__setattr__(self, "del_rad", d)
        object.__setattr__(self, "pop_rad", p)

    def __call__(self, del_rad):
        """POP, rad, by linear interpolation in Del (rad), clamped outside the table; NaN stays NaN."""
        d = np.asarray(del_rad, float)
        return np.where(np.isnan(d), np.nan, np.interp(d, self.del_rad, self.pop_rad))

    def to_csv(self, path, comments=()) -> None:
        """Write the table as ``del_arcmin,pop_arcmin`` CSV, with ``comments`` as leading ``#`` lines."""
        Path(path).write_text(self.to_csv_text(comments), encoding="utf-8")

    def to_csv_text(self, comments=()) -> str:
        """The CSV text of :meth:`to_csv`."""
        lines = [f"# {c}" for c in comments]
        lines.append(",".join(CSV_COLUMNS))
        lines += [f"{d / ARCMIN_RAD:.6f},{p / ARCMIN_RAD:.6f}" for d, p in zip(self.del_rad, self.pop_rad)]
        return "\n".join(lines) + "\n"

    @classmethod
    def from_csv(cls, path) -> "CorrectionTable":
        """Load a ``del_arcmin,pop_arcmin`` CSV file; ValueError naming the file and line if it is malformed.

        Only a regular text file of bounded size is read, without blocking
        (:func:`pmv_ros.storage.files.read_text_file`); no reason quotes the file.
        """
        return cls.from_csv_text(read_text_file(path, "correction table"), source=str(path))

    @classmethod
    def from_csv_text(cls, text: str, source: str = "<text>") -> "CorrectionTable":
        """Parse the CSV text of a table (see :meth:`from_csv`)."""
        rows = [(n, line) for n, line in enumerate(text.splitlines(), 1)
                if line.strip() and not line.lstrip().startswith("#")]
        if not rows:
            raise ValueError(f"correction table {source} is empty")
        first_line, header = rows[0]
        names = [c.strip().lower() for c in next(csv.reader(io.StringIO(header)))]
        if names != list(CSV_COLUMNS):
            # The reason names the line, never quotes it: the file may be anything.
            raise ValueError(f"correction table {source} line {first_line}: the header must be "
                             f"'{','.join(CSV_COLUMNS)}'")
        values = []
        for n, line in rows[1:]:
            cells = next(csv.reader(io.StringIO(line)))
            try:
                if len(cells) != 2:
                    raise ValueError
                del_arcmin, pop_arcmin = (float(c) for c in cells)
                if not (math.isfinite(del_arcmin) and math.isfinite(pop_arcmin)):
                    raise ValueError
            except ValueError:
                raise ValueError(f"correction table {source} line {n}: expected two finite numbers") from None
            values.append((del_arcmin, pop_arcmin))
        if len(values) < 2:
            raise ValueError(f"correction table {source} needs at least 2 rows, got {len(values)}")
        values.sort()
        table = np.array(values) * ARCMIN_RAD
        if np.any(np.diff(table[:, 0]) <= 0.0):
            raise ValueError(f"correction table {source} has repeated Del values")
        return cls(table[:, 0], table[:, 1], source=source)


def simulate_rig(altitude_m, radiances_ru=RIG_RADIANCES_RU, params=None, window_height_m=None,
                 earth_radius_m=EARTH_MEAN_RADIUS_M):
    """The calibration rig: a uniform Earth of each radiance seen from ``altitude_m`` (Model A conditions).

    Args:
        altitude_m: altitude of the orbit the rig imitates, m.
        radiances_ru: rig radiances, r.u.
        params: chain parameters (default: the calibrated ones).
        window_height_m: h_w of the rig's horizon, m (default ``params.window_height_m``).
        earth_radius_m: sphere radius, m.

    Returns:
        (del_rad, gam_rad, geometric_gam_rad): Del and Gam per radiance, and
        θ₀ − φ₀, the crossing angle of the hard-Earth horizon.
    """
    params = DEFAULT_CHAIN_PARAMETERS if params is None else params
    h_w = params.window_height_m if window_height_m is None else float(window_height_m)
    phi0, slope = sphere_chord(altitude_m, earth_radius_m)
    theta0 = scan_start_nadir_angle(phi0, slope, max(params.co2_top_height_m, h_w), params, earth_radius_m)
    readings = sense_horizon_chords(phi0, slope, np.asarray(radiances_ru, float), scan_start_nadir_rad=theta0,
                                    window_height_m=h_w, earth_radius_m=earth_radius_m, params=params)
    if np.any(readings.status != 0):
        bad = np.asarray(radiances_ru, float)[readings.status != 0]
        raise ValueError(f"the rig simulation failed for radiances {bad.tolist()} r.u. (no threshold crossing)")
    return readings.del_rad, readings.gam_rad, float(theta0 - phi0)


def rig_correction_table(altitude_m, params=None, radiances_ru=RIG_RADIANCES_RU, window_height_m=None,
                         earth_radius_m=EARTH_MEAN_RADIUS_M) -> CorrectionTable:
    """The table F(Del) the calibration rig produces for an orbit altitude (see the module docstring).

    Args: as :func:`simulate_rig`.
    """
    del_rad, gam_rad, geometric = simulate_rig(altitude_m, radiances_ru, params, window_height_m, earth_radius_m)
    order = np.argsort(del_rad)
    return CorrectionTable(del_rad[order], gam_rad[order] - geometric,
                           source=f"calibration rig, {float(altitude_m) / 1e3:g} km")


def stored_table_name(altitude_km: int) -> str:
    """File name in pmv_ros/data/ of the shipped rig table for an altitude in km."""
    return f"correction_rig_{altitude_km}km.csv"


def calibrated_correction_table(altitude_m, params=None) -> CorrectionTable:
    """The instrument's calibrated table for an orbit: the shipped one at 500/835 km, else a fresh rig run.

    The shipped files were produced by tools/calibrate_chain.py with the
    default chain parameters; with any other parameters the rig is simulated.
    """
    altitude_km = float(altitude_m) / 1e3
    if params is None or params == DEFAULT_CHAIN_PARAMETERS:
        for stored in STORED_TABLE_ALTITUDES_KM:
            if abs(altitude_km - stored) < 1e-6:
                name = stored_table_name(stored)
                text = resources.files("pmv_ros").joinpath("data", name).read_text(encoding="utf-8")
                return CorrectionTable.from_csv_text(text, source=f"pmv_ros/data/{name}")
    return rig_correction_table(altitude_m, params)


#: Allowed gain s of a stored curve with a gain error (see :func:`scaled_correction_table`): 1 < s ≤ 2
#: (physics.md §3.2 item 1). s = 1, the working curve itself, is accepted too.
SCALE_BOUNDS = (1.0, 2.0)
#: The stored curve inferred for Meteor-M No.2-2 (tools/calibrate_environment.py writes it), and its orbit.
METEOR_M2_2_TABLE = "correction_meteor_m2_2_835km.csv"
METEOR_M2_2_ALTITUDE_KM = 835


def scaled_correction_table(table: CorrectionTable, scale: float) -> CorrectionTable:
    """A stored curve with a gain error: POP_s(Del) = s·POP(Del), the working curve stored ``scale`` times too large.

    physics.md §3.2 item 1, an inference from the Meteor-M No.2-2 record (not a
    published fact): its curve "did not allow the brightness error to be
    corrected", yet its pitch k = 2 is about half of No.2's — which only a
    curve that over-corrects can give (no curve doubles k = 2 in this chain,
    and a rig pulse steeper than flight's under-corrects). A table stored with
    the wrong scale does it: at s ≈ 2 the brightness error comes back at full
    size with the opposite sign. Per chord the corrected angle is then
    Gam − s·POP, so every pair angle is β_raw + s·(β_working − β_raw), exactly.

    Args:
        table: the working (rig) curve.
        scale: s, in :data:`SCALE_BOUNDS`.
    """
    s = float(scale)
    if not (math.isfinite(s) and SCALE_BOUNDS[0] <= s <= SCALE_BOUNDS[1]):
        raise ValueError(f"curve scale = {scale} is outside the allowed range "
                         f"{SCALE_BOUNDS[0]:g} … {SCALE_BOUNDS[1]:g}")
    return CorrectionTable(table.del_rad, s * table.pop_rad,
                           source=f"{table.source or 'rig curve'} with a gain error ×{s:g}")


def meteor_m2_2_table() -> CorrectionTable:
    """The over-correcting stored curve inferred for Meteor-M No.2-2: the working curve × s
    (shipped in pmv_ros/data/)."""
    text = resources.files("pmv_ros").joinpath("data", METEOR_M2_2_TABLE).read_text(encoding="utf-8")
    return CorrectionTable.from_csv_text(text, source=f"pmv_ros/data/{METEOR_M2_2_TABLE}")


def table_comment_value(text: str, key: str):
    """The value of a ``# key: value`` comment line of a table's text, or None."""
    for line in text.splitlines():
        if line.startswith("#") and line[1:].strip().startswith(f"{key}:"):
            return line[1:].strip()[len(key) + 1:].strip()
    return None


def load_correction(spec, altitude_m, params=None):
    """The correction to fly with, from a word or a path: 'calibrated', 'meteor_m2_2', 'none' or a CSV file.

    'meteor_m2_2' is the over-correcting curve inferred for Meteor-M No.2-2, the
    working curve × s (:func:`meteor_m2_2_table`; a curve of the 835 km orbit). Returns a
    :class:`CorrectionTable`, or None for 'none'. ValueError for an unreadable file.
    """
    word = str(spec).strip()
    if word.lower() in ("calibrated", "rig"):
        return calibrated_correction_table(altitude_m, params)
    if word.lower() == "none":
        return None
    if word.lower() == "meteor_m2_2":
        if abs(float(altitude_m) / 1e3 - METEOR_M2_2_ALTITUDE_KM) > 1e-6:
            raise ValueError(f"'meteor_m2_2' is the stored curve of the {METEOR_M2_2_ALTITUDE_KM} km orbit; this orbit "
                             f"is at {float(altitude_m) / 1e3:g} km (use calibrated, none or a table of your own)")
        return meteor_m2_2_table()
    return CorrectionTable.from_csv(word)
