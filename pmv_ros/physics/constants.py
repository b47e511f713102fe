"""Physical and instrument constants, each with its unit and source.

Sources: GRS80 (Moritz, "Geodetic Reference System 1980"); physics.md of this
project for the instrument (§1) and the radiance unit (§3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Ellipsoid:
    """An oblate ellipsoid of revolution: equatorial radius and inverse flattening."""

    name: str
    a_m: float
    inv_f: float

    @property
    def f(self) -> float:
        """Flattening (dimensionless)."""
        return 1.0 / self.inv_f if math.isfinite(self.inv_f) else 0.0

    @property
    def b_m(self) -> float:
        """Polar radius, m."""
        return self.a_m * (1.0 - self.f)


#: GRS80 ellipsoid, a = 6378.137 km, 1/f = 298.257222101 (polar radius 6356.752 km).
GRS80 = Ellipsoid("GRS80", a_m=6378137.0, inv_f=298.257222101)

#: Mean Earth radius used by the published method, m (physics.md §2).
EARTH_MEAN_RADIUS_M = 6371000.0

#: A sphere of the mean radius, for tests and studies that switch oblateness off.
SPHERE = Ellipsoid("sphere", a_m=EARTH_MEAN_RADIUS_M, inv_f=math.inf)

#: Geocentric gravitational constant GM, m^3/s^2 (GRS80 defining constant).
GM_EARTH_M3_S2 = 3.986005e14

#: Second zonal harmonic J2 (GRS80 defining constant J2 = 108263e-8).
J2_EARTH = 1.08263e-3

#: Earth rotation rate, rad/s (GRS80 defining constant).
EARTH_ROTATION_RATE_RAD_S = 7.292115e-5

#: One arc minute, rad.
ARCMIN_RAD = math.pi / (180.0 * 60.0)

#: One arc second, rad.
ARCSEC_RAD = ARCMIN_RAD / 60.0

#: Radiance unit of the papers: 1 r.u. = J = L_min = 2.5 mW/(cm^2 sr) (physics.md §3).
RADIANCE_UNIT_MW_CM2_SR = 2.5

#: One day of 86 400 SI seconds (UTC days without leap seconds; the ephemeris' and the fields' day).
SECONDS_PER_DAY = 86400.0
