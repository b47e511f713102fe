"""The assembled environment: :class:`EnvironmentParameters` in, :class:`RadianceEnvironment` out.

:class:`RadianceEnvironment` puts the climatology, the weather and the layer
heights together and samples them at points and times in one pass
(:class:`HorizonEnvironmentSample`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..constants import EARTH_MEAN_RADIUS_M, SECONDS_PER_DAY
from ..orbit.two_body import check_range
from ..radiance import CO2_TOP_HEIGHT_M
from .climatology import horizon_radiance_climatology
from .fields import _check_count, _flat_points, _seed_sequence, _shaped, _SpectralBank
from .weather import WINDOW_HALF_RANGE_M, LayerHeightField, WeatherField, background_radius_m, synoptic_degrees

#: Shortest wavelength of the flight environment's fields, m: the sensor's IFOV is 2γ = 2.2° wide across
#: its chord, ≈ 100 km of limb at the slant range of 500 km (≈ 130 km at 835 km), so structure finer than
#: this reaches the comparators averaged out. Components drawn beyond it are clipped to it (the variance,
#: e.g. σ_h = 10 km, is kept); it also bounds how fast a field can change along a chord's track, which lets
#: the sensor keep it on a grid along the horizon (pmv_ros/physics/instrument/horizon_fields.py).
IFOV_MIN_WAVELENGTH_M = 100e3
#: Shortest wavelength of the flight weather, m: the weather is a horizon level per chord (physics.md §3.2
#: item 3), the level of the ≈ 1000 km of ground the comparators weigh, so finer weather would not act as
#: one. The synoptic band (zones ≥ 1600 km) is far above it; ≈ 10 % of the red background's variance is
#: moved up to it at R_b ≈ 1000 km.
WEATHER_MIN_WAVELENGTH_M = 300e3
#: Where a chord's sensor takes the latitude/season climatology (:attr:`EnvironmentParameters.climatology_sampling`):
#: ``horizon`` — once per chord, at its horizon (limb) point, a level that scales the chord's whole profile
#: like the weather's (physics.md §3.2 item 3, extended); ``line_of_sight`` — at the horizon
#: point and where the lines of sight below it hit the ground, the profile following the climatology
#: inwards (the earlier model, kept for comparison).
CLIMATOLOGY_SAMPLINGS = ("horizon", "line_of_sight")


@dataclass(frozen=True)
class EnvironmentParameters:
    """Configuration of the radiance environment (SI units; radiance in r.u.).

    Switches: ``climatology_enabled = False`` replaces the climatology by the
    uniform ``uniform_radiance_ru``; ``weather_enabled = False`` removes the
    weather anomaly; ``height_variation_enabled = False`` fixes the window
    layer at ``window_height_mean_m`` and the CO₂ layer at ``co2_height_m``.
    With all three off the environment is the uniform Earth of the
    calibration rig (model A with B(1) = B(2)).

    Fields:
        climatology_enabled: use the latitude/season climatology.
        uniform_radiance_ru: radiance when the climatology is off, r.u.
            (0.3 … 10; physics.md §3 mean 2.4).
        epoch_day_of_year: day of year at simulation time 0, days (0 … 367;
            default 15: the southern summer of the physics.md §3.1 example).
        climatology_sampling: how the sensor samples the climatology along a chord, one of
            :data:`CLIMATOLOGY_SAMPLINGS`: ``"horizon"`` (default; one value per chord at its horizon
            point, scaling the whole profile, physics.md §3.2 item 3) or ``"line_of_sight"`` (the
            climatology wherever the line of sight meets the ground). The layer heights are taken at
            the horizon point either way; the fields themselves do not depend on it.
        weather_enabled: add the correlated weather anomaly.
        relative_variability: η, σ_B/B_mean at a point (0 … 1; physics.md §3.1: 0.2 at nadir,
            η′ = 0.15 after slant viewing and the IFOV at 500 km; §3.2: up to ≈ 0.3).
        correlation_radius_m: R_x, e-folding distance of the weather correlation, m
            (10 … 6371 km; 300 km theory, 700 km flight).
        synoptic_fraction: share w of the weather variance in the synoptic band (0 … 0.95;
            0 = the exponential weather of the modelling paper), see :class:`WeatherField`.
        synoptic_zone_m: length of the synoptic zones along the track, m (500 … 10000 km; 2000 km flight).
        synoptic_components: sectoral components of the band field (16 … 8192).
        min_wavelength_m: shortest wavelength of the layer-height fields, m (0.1 … 1000 km; default
            :data:`IFOV_MIN_WAVELENGTH_M`, what the IFOV resolves).
        weather_min_wavelength_m: shortest wavelength of the weather's background, m (0.1 … 1000 km;
            default :data:`WEATHER_MIN_WAVELENGTH_M`, what the line-of-sight sampling resolves).
        time_scale_s: e-folding time of weather and layer height, s
            (≥ 60 s, ``math.inf`` = frozen; default one day, an assumption).
        n_components: cosines per random field (16 … 8192).
        height_variation_enabled: let the window-layer height vary.
        window_height_mean_m: mean window-layer height, m (physics.md §3: 40 km).
        window_height_half_range_m: half-width of its uniform spread, m (√3·10 km = 17.3 km:
            σ_h = 10 km, physics.md §3.2 item 4 — 40 ± 20 km read as the ±2σ range).
        height_correlation_radius_m: e-folding radius of the (exponential) height field, m;
            ``None`` = the weather's. The flight environment uses mesoscale values
            (a few hundred km or less, physics.md §3.2 item 4); the height field is
            independent of the weather (our choice: the window-layer height is set by
            the humidity and temperature structure of the lower troposphere, which the
            6–20 µm radiance anomaly does not determine).
        co2_height_m: CO₂-layer height, m (20 … 120 km; physics.md §3: ≈ 60 km).
        co2_height_half_range_m: half-width of a uniform spread of the CO₂
            layer, m (0 … 1 km; physics.md §3: spread < 0.5 km; default 0 = fixed).
        seed: int ≥ 0; the weather, window-height and CO₂-height fields get
            independent streams spawned from it.
        field_time_origin_s: the random fields' time at simulation time 0, s (|t₀| ≤ 10¹⁰ s). The
            flight environment gives UTC, seconds since J2000.0 (2000-01-01 12:00 UTC) at the clock's
            zero, so weather and layer height are functions of position and absolute time (physics.md
            §3.2 item 6): campaign days see different weather, and a real-time and a fast-time run of
            one epoch see the same fields. 0 (the default): the fields run on the simulation clock.
    """

    climatology_enabled: bool = True
    uniform_radiance_ru: float = 2.4
    epoch_day_of_year: float = 15.0
    climatology_sampling: str = "horizon"
    weather_enabled: bool = True
    relative_variability: float = 0.15
    correlation_radius_m: float = 700e3
    time_scale_s: float = SECONDS_PER_DAY
    n_components: int = 256
    synoptic_fraction: float = 0.0
    synoptic_zone_m: float = 2000e3
    synoptic_components: int = 128
    min_wavelength_m: float = IFOV_MIN_WAVELENGTH_M
    weather_min_wavelength_m: float = WEATHER_MIN_WAVELENGTH_M
    height_variation_enabled: bool = True
    window_height_mean_m: float = 40e3
    window_height_half_range_m: float = WINDOW_HALF_RANGE_M
    height_correlation_radius_m: float | None = None
    co2_height_m: float = CO2_TOP_HEIGHT_M
    co2_height_half_range_m: float = 0.0
    seed: int = 0
    field_time_origin_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("climatology_enabled", "weather_enabled", "height_variation_enabled"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise ValueError(f"{name} = {getattr(self, name)!r} must be true or false")
        check_range("uniform radiance", self.uniform_radiance_ru, 0.3, 10.0, " r.u.")
        check_range("epoch day of year", self.epoch_day_of_year, 0.0, 367.0)
        if self.climatology_sampling not in CLIMATOLOGY_SAMPLINGS:
            raise ValueError(f"climatology sampling = {self.climatology_sampling!r} is not one of "
                             f"{', '.join(CLIMATOLOGY_SAMPLINGS)}")
        check_range("relative variability η′", self.relative_variability, 0.0, 1.0)
        check_range("correlation radius", self.correlation_radius_m / 1e3, 10.0, EARTH_MEAN_RADIUS_M / 1e3, " km")
        check_range("time scale", self.time_scale_s, 60.0, math.inf, " s")
        _check_count("number of spectral components", self.n_components, 16, 8192)
        check_range("synoptic fraction", self.synoptic_fraction, 0.0, 0.95)
        check_range("synoptic zone length", self.synoptic_zone_m / 1e3, 500.0, 10000.0, " km")
        _check_count("number of synoptic components", self.synoptic_components, 16, 8192)
        check_range("shortest wavelength", self.min_wavelength_m / 1e3, 0.1, 1000.0, " km")
        check_range("shortest weather wavelength", self.weather_min_wavelength_m / 1e3, 0.1, 1000.0, " km")
        if self.weather_enabled:
            background_radius_m(self.correlation_radius_m, self.synoptic_fraction,
                                synoptic_degrees(self.synoptic_zone_m))
        check_range("window layer height", self.window_height_mean_m / 1e3, 5.0, 150.0, " km")
        check_range("window layer half-range", self.window_height_half_range_m / 1e3, 0.0,
                    self.window_height_mean_m / 1e3, " km")
        if self.height_correlation_radius_m is not None:
            check_range("height correlation radius", self.height_correlation_radius_m / 1e3, 10.0,
                        EARTH_MEAN_RADIUS_M / 1e3, " km")
        check_range("CO2 layer height", self.co2_height_m / 1e3, 20.0, 120.0, " km")
        check_range("CO2 layer half-range", self.co2_height_half_range_m / 1e3, 0.0, 1.0, " km")
        check_range("field time origin", self.field_time_origin_s, -1e10, 1e10, " s")
        # The window layer lies under the CO₂ layer (physics.md §3 profile
        # order).
        top_of_window_km = (self.window_height_mean_m + self.window_height_half_range_m) / 1e3
        bottom_of_co2_km = (self.co2_height_m - self.co2_height_half_range_m) / 1e3
        check_range("top of the window layer", top_of_window_km, 0.0, bottom_of_co2_km, " km")
        _seed_sequence(self.seed)


@dataclass(frozen=True)
class HorizonEnvironmentSample:
    """The environment at a set of points: arrays of the points' broadcast shape.

    Fields:
        horizon_radiance_ru: radiance B_m of the lower atmosphere, r.u.
        window_height_m: height h_w of the window-emitting layer, m.
        co2_height_m: height of the CO₂ layer, m.
        mean_radiance_ru: the radiance without weather (climatology or uniform), r.u.
    """

    horizon_radiance_ru: np.ndarray
    window_height_m: np.ndarray
    co2_height_m: np.ndarray
    mean_radiance_ru: np.ndarray


class RadianceEnvironment:
    """The horizon radiance environment of physics.md §3: climatology, weather and layer heights.

    Args:
        parameters: an :class:`EnvironmentParameters` (defaults: everything on,
            η′ = 0.15, R_x = 700 km, τ = 1 day, h_w = 40 km with σ_h = 10 km, CO₂ at 60 km).
    """

    def __init__(self, parameters: EnvironmentParameters | None = None) -> None:
        p = EnvironmentParameters() if parameters is None else parameters
        self.parameters = p
        weather_seed, window_seed, co2_seed = np.random.SeedSequence(p.seed).spawn(3)
        height_radius_m = p.correlation_radius_m if p.height_correlation_radius_m is None \
            else p.height_correlation_radius_m
        self.weather = WeatherField(p.relative_variability, p.correlation_radius_m, p.time_scale_s,
                                    p.n_components, weather_seed, p.synoptic_fraction, p.synoptic_zone_m,
                                    p.synoptic_components, p.weather_min_wavelength_m, p.field_time_origin_s) \
            if p.weather_enabled else None
        self.window_layer = LayerHeightField(p.window_height_mean_m, p.window_height_half_range_m,
                                             height_radius_m, p.time_scale_s, p.n_components, window_seed,
                                             p.min_wavelength_m, p.field_time_origin_s) \
            if p.height_variation_enabled and p.window_height_half_range_m > 0.0 else None
        self.co2_layer = LayerHeightField(p.co2_height_m, p.co2_height_half_range_m, height_radius_m,
                                          p.time_scale_s, p.n_components, co2_seed, p.min_wavelength_m,
                                          p.field_time_origin_s) \
            if p.height_variation_enabled and p.co2_height_half_range_m > 0.0 else None

        # All random fields in one cosine pass (see sample()).
        self._fields = [f for f in (self.weather and self.weather.anomaly_field,
                                    self.window_layer and self.window_layer.gaussian_field,
                                    self.co2_layer and self.co2_layer.gaussian_field) if f is not None]
        self._bank = _SpectralBank([f.components for f in self._fields],
                                   max((f.dtype for f in self._fields), key=lambda d: d.itemsize)) \
            if self._fields else None
        # The weather alone, for points where only the radiance is wanted (sample(layers=False)).
        self._weather_bank = _SpectralBank([self.weather.anomaly_field.components], self.weather.anomaly_field.dtype) \
            if self.weather else None

    def day_of_year(self, t_s):
        """Day of year at simulation time ``t_s`` (s): epoch day + t/86400, days."""
        return self.parameters.epoch_day_of_year + np.asarray(t_s, float) / SECONDS_PER_DAY

    def mean_radiance_ru(self, lat_rad, t_s):
        """Radiance without weather, r.u.: the climatology, or the uniform value when it is off.

        Args:
            lat_rad: geocentric latitude, rad.
            t_s: simulation time, s (sets the day of year).
        """
        if self.parameters.climatology_enabled:
            return horizon_radiance_climatology(lat_rad, self.day_of_year(t_s))
        return self.parameters.uniform_radiance_ru + 0.0 * (np.asarray(lat_rad, float) + np.asarray(t_s, float))

    def sample(self, lat_rad, lon_rad, t_s, *, layers: bool = True) -> HorizonEnvironmentSample:
        """Everything the horizon profile needs at points and times (see :class:`HorizonEnvironmentSample`).

        One pass: the random fields share the trigonometry of the points and
        one cosine evaluation, so this is cheaper than the three methods below
        called one by one (and gives the same values).

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
            layers: False for points where only the radiance is wanted (the
                sensor's probe points inside the horizon): the layer-height
                fields are not evaluated and the heights come back NaN.
        """
        lat, lon, t, shape = _flat_points(lat_rad, lon_rad, t_s)
        bank = self._bank if layers else self._weather_bank
        values = bank.evaluate(lat, lon, t) if bank is not None else None
        column = iter(range(len(self._fields)))
        mean = self.mean_radiance_ru(lat, t) + 0.0 * lon
        if self.weather is not None:
            band = None if self.weather.band_field is None else self.weather.band_field.evaluate(lat, lon, t)
            radiance = self.weather.radiance_from_anomaly(mean, self.weather.combine(values[:, next(column)], band))
        else:
            radiance = mean
        heights = []
        for layer, constant_m in ((self.window_layer, self.parameters.window_height_mean_m),
                                  (self.co2_layer, self.parameters.co2_height_m)):
            if not layers:
                heights.append(np.full(lat.shape, np.nan))
            elif layer is not None:
                heights.append(layer.height_from_gaussian(values[:, next(column)]))
            else:
                heights.append(constant_m + 0.0 * (lat + lon + t))
        return HorizonEnvironmentSample(_shaped(radiance, shape), _shaped(heights[0], shape),
                                        _shaped(heights[1], shape), _shaped(mean, shape))

    def background_anomaly(self, lat_rad, lon_rad, t_s):
        """The weather's red background g (σ = 1) at points, flat; zeros without weather."""
        lat, lon, t, _ = _flat_points(lat_rad, lon_rad, t_s)
        if self.weather is None:
            return np.zeros(lat.size)
        return self._weather_bank.evaluate(lat, lon, t)[:, 0]

    def synoptic_band(self, lat_rad, lon_rad, t_s):
        """The synoptic band field s (σ = 1) at points, flat; None when the weather has no band."""
        if self.weather is None or self.weather.band_field is None:
            return None
        lat, lon, t, _ = _flat_points(lat_rad, lon_rad, t_s)
        return self.weather.band_field.evaluate(lat, lon, t)

    def radiance_from_parts(self, mean_radiance_ru, background, band):
        """Horizon radiance, r.u., from its parts: the radiance without weather (:meth:`mean_radiance_ru`), the
        background g (:meth:`background_anomaly`) and the band s (:meth:`synoptic_band`; may be None).

        :meth:`sample`'s radiance in pieces, for the sensor, which interpolates them in time along a chord's
        track. The parts broadcast: the sensor gives the climatology at a chord's horizon point (or along
        its line of sight) and the anomaly of its horizon point only (physics.md §3.2 item 3).
        """
        if self.weather is None:
            return np.asarray(mean_radiance_ru, float)
        return self.weather.radiance_from_anomaly(mean_radiance_ru, self.weather.combine(background, band))

    def horizon_radiance_ru(self, lat_rad, lon_rad, t_s):
        """Horizon radiance B_m with climatology and weather, r.u.

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
        """
        mean = self.mean_radiance_ru(lat_rad, t_s)
        if self.weather is None:
            return mean + 0.0 * np.asarray(lon_rad, float)
        return self.weather.radiance_ru(mean, lat_rad, lon_rad, t_s)

    def window_height_m(self, lat_rad, lon_rad, t_s):
        """Height of the window-emitting layer h_w, m.

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
        """
        return self._layer(self.window_layer, self.parameters.window_height_mean_m, lat_rad, lon_rad, t_s)

    def co2_height_m(self, lat_rad, lon_rad, t_s):
        """Height of the CO₂ layer, m (constant unless a spread is configured).

        Args:
            lat_rad: geocentric latitude, rad (Earth-fixed).
            lon_rad: longitude, rad (Earth-fixed).
            t_s: simulation time, s.
        """
        return self._layer(self.co2_layer, self.parameters.co2_height_m, lat_rad, lon_rad, t_s)

    @staticmethod
    def _layer(field, constant_m, lat_rad, lon_rad, t_s):
        """A layer's height from its field, or the constant (broadcast; NaN-propagating) when fixed."""
        if field is not None:
            return field.height_m(lat_rad, lon_rad, t_s)
        return constant_m + 0.0 * (np.asarray(lat_rad, float) + np.asarray(lon_rad, float) + np.asarray(t_s, float))
