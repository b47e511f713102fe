"""The real sky the tracker sees: the shipped Hipparcos-2 table, moved to the date, and the stars in a field.

physics.md §6 item 1. ``pmv_ros/data/star_sky.bin`` (``tools/make_star_table.py``)
holds the 26547 brightest Hipparcos-2 stars by Hp, in that order, at the
catalogue epoch J1991.25: the on-board catalogue is the first
``catalogue_stars`` of them (8350, Hp ≤ 6.54), the rest are stars the
tracker registers but does not know. :class:`Sky` moves them to the run's
date (linear proper motion, then IAU 1976 precession from J2000 to the mean
equator and equinox of date — the frame the orbit's ECI is in; the ≈ 20 mas
frame bias of ICRS is left out) and finds the stars in a square field about
a boresight (:meth:`Sky.stars_in_fields`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..constants import ARCSEC_RAD
from .kernel import field_stars_batch
from .tables import data_path, read_table

SKY_FILE = "star_sky.bin"
#: Julian date of the Hipparcos catalogue epoch J1991.25 (TT), days.
HIPPARCOS_EPOCH_JD = 2448349.0625
JD_J2000 = 2451545.0
DAYS_PER_JULIAN_YEAR = 365.25
MAS_RAD = ARCSEC_RAD / 1000.0


def precession_matrix(julian_date_tt: float) -> np.ndarray:
    """Rotation from the J2000 mean equator and equinox to those of date, ``(3, 3)`` (IAU 1976, Lieske et al. 1977)."""
    t = (julian_date_tt - JD_J2000) / 36525.0
    zeta = (2306.2181 * t + 0.30188 * t * t + 0.017998 * t ** 3) * ARCSEC_RAD
    z = (2306.2181 * t + 1.09468 * t * t + 0.018203 * t ** 3) * ARCSEC_RAD
    theta = (2004.3109 * t - 0.42665 * t * t - 0.041833 * t ** 3) * ARCSEC_RAD

    def about_z(angle):
        c, s = math.cos(angle), math.sin(angle)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def about_y(angle):
        c, s = math.cos(angle), math.sin(angle)
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])

    return about_z(z) @ about_y(-theta) @ about_z(zeta)


@dataclass(frozen=True)
class FieldStars:
    """The stars in a batch of square fields, flat: one entry per (field, star), grouped by field.

    ``field`` (S,) the field's index; ``star`` (S,) the star's row of the sky
    (0 the brightest); ``u_rad``, ``v_rad`` (S,) its focal-plane coordinates
    (tangent-plane, along the tracker's first and second axes, rad);
    ``hp_mag`` (S,) its Hp.
    """

    field: np.ndarray
    star: np.ndarray
    u_rad: np.ndarray
    v_rad: np.ndarray
    hp_mag: np.ndarray


#: Cells of the sky index: a cube's faces cut into CELLS_PER_EDGE² squares each (≈ 2.8° at 32).
CELLS_PER_EDGE = 32
#: Most field half-width served, rad (a 40° square: the field-of-view parameter's largest).
MAX_HALF_WIDTH_RAD = math.radians(20.0)


def _cell_centres() -> np.ndarray:
    """Unit vectors of the centres of every sky-index cell, ``(3, 6·CELLS_PER_EDGE²)``, in cell order."""
    centre = (np.arange(CELLS_PER_EDGE) + 0.5) / CELLS_PER_EDGE * 2.0 - 1.0
    a, b = np.meshgrid(centre, centre, indexing="ij")
    vectors = []
    for face in range(6):
        axis, sign = face // 2, -1.0 if face % 2 else 1.0
        v = np.zeros((3, a.size))
        others = [[1, 2], [2, 0], [0, 1]][axis]
        v[axis] = sign
        v[others[0]], v[others[1]] = a.ravel(), b.ravel()
        vectors.append(v / np.linalg.norm(v, axis=0))
    return np.concatenate(vectors, axis=1)


#: Largest angle from a cell's centre to a point of the cell, rad (the corners of the central cells of a face).
_CELL_RADIUS_RAD = math.atan(math.sqrt(2.0) / CELLS_PER_EDGE) * 1.01
#: A sky index serves every sky whose stars are within this of their places in the sky it was built on: its cells
#: reach this much further (≈ 2.5 % more candidates a frame, each checked against the field), and the runs of a
#: process on other dates — a campaign's tasks, each a day of the year — share it instead of building one each
#: (≈ 0.1 s). Precession moves the stars ≈ 50″ a year: one index serves some six years either side.
INDEX_MARGIN_RAD = math.radians(0.1)
#: Indexes kept for other skies, by field half-width: (the star directions it was built on, the index).
_SHARED_INDEXES: dict = {}
_SHARED_INDEXES_KEPT = 4


def _build_index(direction_eci: np.ndarray, half_width_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`Sky.index` of the stars at ``direction_eci`` ``(3, S)``: each cell holds every star within the reach of
    a field centred in it, widened by :data:`INDEX_MARGIN_RAD`, in star order."""
    # Imported here: scipy.spatial costs ≈ 0.2 s of every process that imports this module (through the Outcome
    # codes, every node and `pmv` command), and only a tracker building its sky's index needs it.
    from scipy.spatial import cKDTree

    reach = math.atan(math.sqrt(2.0) * math.tan(half_width_rad)) + _CELL_RADIUS_RAD + INDEX_MARGIN_RAD
    found = cKDTree(direction_eci.T).query_ball_point(_cell_centres().T, 2.0 * math.sin(reach / 2.0),
                                                      return_sorted=True)
    counts = np.fromiter(map(len, found), np.int64, len(found))
    stars = np.concatenate([np.asarray(hits, np.int64) for hits in found])
    return np.concatenate([[0], np.cumsum(counts)]), stars


def _within(built_on: np.ndarray, direction_eci: np.ndarray, angle_rad: float) -> bool:
    """Whether every star of ``direction_eci`` ``(3, S)`` is within ``angle_rad`` of its place in ``built_on``."""
    if built_on.shape != direction_eci.shape:
        return False
    chord_squared = float(np.max(np.sum((built_on - direction_eci) ** 2, axis=0), initial=0.0))
    return chord_squared <= (2.0 * math.sin(angle_rad / 2.0)) ** 2


class Sky:
    """The star table at a date, ready for field queries.

    Args:
        julian_date_tt: the date the stars are moved to (TT), days.
        path: the table file (default: the shipped one).
    """

    def __init__(self, julian_date_tt: float, path=None):
        path = data_path(SKY_FILE) if path is None else path
        self.provenance, columns = read_table(path, "star table")
        try:
            ra, dec = np.asarray(columns["ra_rad"], float), np.asarray(columns["dec_rad"], float)
            pm_ra = np.asarray(columns["pm_ra_cosdec_mas_yr"], float) * MAS_RAD
            pm_dec = np.asarray(columns["pm_dec_mas_yr"], float) * MAS_RAD
            self.hp_mag = np.asarray(columns["hp_mag"], float)
            self.hip = np.asarray(columns["hip"], np.int64)
            if not (ra.shape == dec.shape == pm_ra.shape == pm_dec.shape == self.hp_mag.shape == self.hip.shape):
                raise KeyError
        except KeyError:
            raise ValueError(f"star table {path} is corrupt: its columns do not form one table") from None
        years = (julian_date_tt - HIPPARCOS_EPOCH_JD) / DAYS_PER_JULIAN_YEAR
        cos_ra, sin_ra, cos_dec, sin_dec = np.cos(ra), np.sin(ra), np.cos(dec), np.sin(dec)
        position = np.array([cos_dec * cos_ra, cos_dec * sin_ra, sin_dec])
        east = np.array([-sin_ra, cos_ra, np.zeros_like(ra)])
        north = np.array([-sin_dec * cos_ra, -sin_dec * sin_ra, cos_dec])
        moved = position + years * (pm_ra * east + pm_dec * north)
        moved /= np.linalg.norm(moved, axis=0)
        #: Unit vectors of the stars, ECI of date, ``(3, S)``.
        self.direction_eci = np.ascontiguousarray(precession_matrix(julian_date_tt) @ moved)
        self._indexes = {}  # field half-width → (each cell's start, the cells' stars)

    def index(self, half_width_rad: float) -> tuple[np.ndarray, np.ndarray]:
        """For each sky cell, the stars (in brightness order) a field of this half-width centred anywhere in the
        cell can hold, and a few more, as one flat array and each cell's start (built once per field size, and
        shared with the skies of other dates that it serves: :data:`INDEX_MARGIN_RAD`)."""
        index = self._indexes.get(half_width_rad)
        if index is None:
            built_on, index = _SHARED_INDEXES.get(half_width_rad, (None, None))
            if index is None or not _within(built_on, self.direction_eci, INDEX_MARGIN_RAD):
                index = _build_index(self.direction_eci, half_width_rad)
                _SHARED_INDEXES.pop(half_width_rad, None)
                _SHARED_INDEXES[half_width_rad] = (self.direction_eci, index)
                while len(_SHARED_INDEXES) > _SHARED_INDEXES_KEPT:
                    _SHARED_INDEXES.pop(next(iter(_SHARED_INDEXES)))
            self._indexes[half_width_rad] = index
        return index

    def __len__(self) -> int:
        return int(self.hp_mag.size)

    def stars_in_fields(self, axes_eci: np.ndarray, half_width_rad: float, stars: int | None = None) -> FieldStars:
        """The stars inside square fields of half-width ``half_width_rad`` (the field's edge, from its centre).

        Args:
            axes_eci: the tracker's axes in ECI, ``(3, 3, N)``: columns its first and second focal-plane
                axes and its boresight.
            half_width_rad: half the field's side, rad.
            stars: only the ``stars`` brightest of the table (default: all).
        """
        if half_width_rad > MAX_HALF_WIDTH_RAD:
            raise ValueError(f"field half-width {math.degrees(half_width_rad):.2f}° is more than the sky index's "
                             f"{math.degrees(MAX_HALF_WIDTH_RAD):g}°")
        cell_start, cell_stars = self.index(half_width_rad)
        field, star, u_rad, v_rad = field_stars_batch(np.ascontiguousarray(axes_eci, float), half_width_rad,
                                                      len(self) if stars is None else min(stars, len(self)),
                                                      cell_start, cell_stars, CELLS_PER_EDGE, self.direction_eci)
        return FieldStars(field, star, u_rad, v_rad, self.hp_mag[star])
