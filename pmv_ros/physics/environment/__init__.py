"""The radiance environment of the horizon: climatology, weather and layer heights.

What a chord sees behind its horizon depends on where on the rotating Earth the
tangent point lies and when. This package gives, at any Earth-fixed point and
time, the three quantities the horizon profile of physics.md §3 needs:

* the horizon radiance B_m, r.u. — a zonal latitude/season climatology
  (:func:`horizon_radiance_climatology`) times ``1 + η·a``, kept inside
  1 … 4 r.u., where ``a`` is a correlated random weather anomaly
  (:class:`WeatherField`): a synoptic band of zones (:class:`SynopticBandField`,
  the hump of the Meteor-M No.2-2 record) over a red exponential background,
  the covariance documented there (physics.md §3.2);
* the height h_w of the window-emitting layer, uniformly distributed with
  σ_h = 10 km about 40 km (half-width 17.3 km) and spatially correlated, by
  default like the weather, in flight on mesoscales
  (:class:`LayerHeightField`);
* the height of the CO₂ layer, ≈ 60 km, fixed unless a small spread is asked for.

:class:`RadianceEnvironment` assembles them from :class:`EnvironmentParameters`.
The sensor takes the climatology and the weather once per chord, at its horizon
point, as the level of the chord's whole profile (physics.md §3.2 item 3;
``climatology_sampling = "line_of_sight"`` takes the climatology along the line
of sight instead, for comparison).
Together they make the latitude/season, weather and height errors of
physics.md §3.1 (models B, C, D) come out of one model, as in flight.

Coordinates: ``lat_rad``/``lon_rad`` are geocentric latitude and longitude in
the Earth-fixed frame, rad; points are placed on a sphere of the mean radius
(the geodetic/geocentric difference, ≤ 0.19° ≈ 21 km, is far below the
correlation radius). ``t_s`` is the simulation clock, s. All functions accept
scalars or arrays that broadcast together and return the broadcast shape.
NaN inputs give NaN outputs (nothing raises in array code).

The random fields are synthesised pointwise, nothing on a global grid
(:mod:`.fields`). The flight presets' values come from tools/calibrate_environment.py.

The package, bottom up: :mod:`.climatology` (the zonal latitude/season
climatology), :mod:`.fields` (correlated random fields on the sphere),
:mod:`.weather` (the weather anomaly and the layer heights made of them) and
:mod:`.radiance_environment` (the parameters and the assembled environment).
"""

from .climatology import (
    CLIMATOLOGY_DEGREE,
    CLIMATOLOGY_TABLE,
    SEASON_PEAK_DAY,
    YEAR_DAYS,
    horizon_radiance_climatology,
)
from .fields import MIN_WAVELENGTH_M, GaussianSphereField, SynopticBandField
from .radiance_environment import (
    CLIMATOLOGY_SAMPLINGS,
    IFOV_MIN_WAVELENGTH_M,
    WEATHER_MIN_WAVELENGTH_M,
    EnvironmentParameters,
    HorizonEnvironmentSample,
    RadianceEnvironment,
)
from .weather import (
    PRECISE_FIELD_DTYPE,
    WINDOW_HALF_RANGE_M,
    LayerHeightField,
    WeatherField,
    background_radius_m,
    synoptic_degrees,
)

__all__ = [
    "CLIMATOLOGY_DEGREE", "CLIMATOLOGY_TABLE", "SEASON_PEAK_DAY", "YEAR_DAYS", "horizon_radiance_climatology",
    "MIN_WAVELENGTH_M", "GaussianSphereField", "SynopticBandField",
    "PRECISE_FIELD_DTYPE", "WINDOW_HALF_RANGE_M", "LayerHeightField", "WeatherField", "background_radius_m",
    "synoptic_degrees",
    "CLIMATOLOGY_SAMPLINGS", "IFOV_MIN_WAVELENGTH_M", "WEATHER_MIN_WAVELENGTH_M", "EnvironmentParameters",
    "HorizonEnvironmentSample", "RadianceEnvironment",
]
