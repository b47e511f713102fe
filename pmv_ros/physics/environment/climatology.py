"""The zonal latitude/season climatology of the horizon radiance B_m (physics.md §3.1).

An annual mean and a seasonal amplitude, each a Legendre series in sin(latitude)
fitted to :data:`CLIMATOLOGY_TABLE` (the model-B anchors of physics.md §3.1, the
rest assumed), give :func:`horizon_radiance_climatology`, r.u.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import legendre

from ..compiled import elementwise

#: Length of the climatological year, days.
YEAR_DAYS = 365.25

#: Day of year of the northern-summer extreme of the seasonal cycle (≈ 15 July).
#: Assumption: tropospheric temperature lags the solstice by 3–4 weeks. The
#: southern-summer extreme falls half a year earlier, on day ≈ 13 — the
#: "southern summer" of the physics.md §3.1 example (day ≈ 15).
SEASON_PEAK_DAY = 196.0

#: Latitude, deg; radiance in mid-January (southern summer) and mid-July
#: (northern summer), r.u. The smooth climatology is fitted to these rows.
#:
#: Anchors (physics.md §3.1, model B — the largest real gradient, southern
#: summer, sub-satellite point 45° S at 500 km; the horizon points in the
#: meridian plane are 22.0° of arc either side): January 1.6 r.u. at 67° S,
#: 2.6 under the spacecraft at 45° S and 3.5 at 23° S.
#:
#: Everything else is our assumption, shaped after the 6–20 µm numbers of
#: physics.md §3 (≈ 1 r.u. over Antarctica in its winter, ≈ 4 r.u. over the dry
#: subtropics in summer, global mean ≈ 2.4 r.u.) and after the familiar
#: pattern of outgoing long-wave radiation: bright dry subtropics, a darker
#: cloudy band at the equator, a larger seasonal swing over the land-rich
#: northern hemisphere, a colder Antarctic than Arctic. A black body at 224 K
#: gives 1 r.u. in 6–20 µm and one at 299 K gives 4 r.u. (our Planck
#: integration), a sanity check on the range.
CLIMATOLOGY_TABLE = np.array([
    # lat_deg, January_ru, July_ru
    [-90.0, 1.30, 1.00],
    [-78.0, 1.38, 1.00],
    [-67.0, 1.60, 1.05],  # anchor (January)
    [-55.0, 2.05, 1.35],
    [-45.0, 2.60, 1.75],  # anchor (January)
    [-35.0, 3.10, 2.35],
    [-23.0, 3.50, 2.75],  # anchor (January)
    [-12.0, 2.80, 2.50],
    [0.0, 2.20, 2.20],
    [12.0, 2.40, 2.70],
    [23.0, 2.75, 3.80],
    [30.0, 2.55, 4.05],
    [40.0, 2.00, 3.45],
    [50.0, 1.60, 2.75],
    [60.0, 1.30, 2.35],
    [75.0, 1.10, 2.05],
    [90.0, 1.05, 1.95],
])
_ANCHOR_ROWS = (2, 4, 6)
#: The anchors weigh this much more than the assumed rows in the fit.
_ANCHOR_WEIGHT = 5.0
#: Degree of the Legendre series in sin(latitude).
CLIMATOLOGY_DEGREE = 10


def _fit_climatology():
    """Legendre coefficients (in sin lat) of the annual mean and of the seasonal amplitude, r.u.

    A series in sin(latitude) is a smooth function on the sphere (it depends on
    the polar coordinate z only, so it has no cusp at the poles). The fit
    smooths the table; it meets the anchors within 0.01 r.u. and stays within
    0.98 … 4.0 r.u. for every latitude and day (tests/physics/test_environment.py).
    """
    x = np.sin(np.radians(CLIMATOLOGY_TABLE[:, 0]))
    january, july = CLIMATOLOGY_TABLE[:, 1], CLIMATOLOGY_TABLE[:, 2]
    weights = np.ones_like(x)
    weights[list(_ANCHOR_ROWS)] = _ANCHOR_WEIGHT
    annual = legendre.legfit(x, 0.5 * (july + january), CLIMATOLOGY_DEGREE, w=weights)
    seasonal = legendre.legfit(x, 0.5 * (july - january), CLIMATOLOGY_DEGREE, w=weights)
    return annual, seasonal


_ANNUAL_COEFFS, _SEASONAL_COEFFS = _fit_climatology()
#: The same two series in powers of sin(lat), columns (annual, seasonal), for
#: one cheap evaluation (coefficients ≤ 10², so rounding stays ≈ 10⁻¹² r.u.).
_POWER_COEFFS = np.stack([legendre.leg2poly(_ANNUAL_COEFFS), legendre.leg2poly(_SEASONAL_COEFFS)], axis=1)


@elementwise
def climatology_ru(lat_rad, day_of_year):
    """:func:`horizon_radiance_climatology` at one point (the sensor's kernel calls it per chord), r.u."""
    x = math.sin(lat_rad)
    annual = seasonal = 0.0
    power = 1.0
    for k in range(_POWER_COEFFS.shape[0]):  # powers 1, x, x², … of x = sin φ
        annual += _POWER_COEFFS[k, 0] * power
        seasonal += _POWER_COEFFS[k, 1] * power
        power *= x
    return annual + math.cos((2.0 * math.pi / YEAR_DAYS) * (day_of_year - SEASON_PEAK_DAY)) * seasonal


def horizon_radiance_climatology(lat_rad, day_of_year):
    """Climatological horizon radiance B_m at a latitude and day of year, r.u.

    B(φ, d) = A(sin φ) + S(sin φ)·cos(2π(d − 196)/365.25): an annual mean A
    and a seasonal amplitude S, each a degree-10 Legendre series in sin φ
    fitted to :data:`CLIMATOLOGY_TABLE` (anchors from physics.md §3.1, the rest
    assumed — see the table). Zonal: no longitude dependence (land/sea
    contrast is left to the weather field). Its global, annual mean is
    A's constant term, ≈ 2.46 r.u. (physics.md §3: ≈ 2.4).

    Args:
        lat_rad: geocentric latitude, rad (array-like).
        day_of_year: day of the year, days (1.0 = 1 January 00:00; fractional,
            any real — the cycle repeats every 365.25 days).

    Returns:
        Radiance, r.u. (1 r.u. = 2.5 mW/(cm²·sr)), broadcast shape of the inputs.
    """
    out = climatology_ru(lat_rad, day_of_year)
    return out[()] if np.ndim(out) == 0 else out
