"""The star tracker's frames on the real sky: what it sees, whether it recognises it, and how well (physics.md §6).

A frame, in the order of physics.md §6:

1. where the tracker points — the true attitude on the orbit's frame at the
   frame's time (the middle of the exposure, item 2), the boresight and its
   two focal-plane axes in ECI of date;
2. the rate it turns at inertially, across and about the boresight, and the
   smear that costs ΔM_rate (item 3); above the hard ceiling: ``rate_too_high``;
3. Sun, Moon and the Earth's limb: inside their exclusion angles,
   ``exclusion``; just outside, the stray light costs ΔM_background (item 8);
4. the stars in the square field (:class:`~.sky.Sky`) brighter than the
   detection limit m_det = catalogue limit + margin − ΔM_rate − ΔM_background
   (item 3);
5. proton hits — AP8 trapped protons (:class:`~.radiation.RadiationGrid`)
   and a solar event where the McIlwain L lets it in — Poisson a frame
   through the CCD's two windows; their pixels and the stars' fill the
   video buffer: ``buffer_overflow`` (items 6 and 7);
6. the K brightest objects (stars with a ranking scatter, and hits) go to
   recognition: fewer than 3 catalogue stars among them, ``no_stars``;
   otherwise it fails with p = 1 − (1 − p3·e^−(n−3)/n_s)·(1 − p_conf)^(others
   among the K): ``recognition_failure`` (item 4);
7. the attitude from the catalogue stars used: each star's centroid error
   (half of its variance a bias of that star, half drawn anew each frame,
   raised by the smear) fitted as a small rotation — across the boresight
   σ/√n, about it σ/(r_rms·√n) (item 5).

Every random draw is keyed by the frame's time (and the star's HIP number):
:mod:`.draws`. Outage windows are an operator override (item 9). An
``ideal`` tracker skips 1–7: every frame outside an outage gives the true
attitude.

Array code does not raise for bad samples: a frame without output gets a
reason code (:class:`Outcome`) and a NaN quaternion.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..constants import ARCSEC_RAD, GRS80
from ..orbit.ephemeris import Epoch, moon_position_eci_m, sun_position_eci_m
from ..orbit.two_body import orbital_frame_from_state
from .draws import seed_hash
from .kernel import (ABOUT_BORESIGHT_LEVER, CONFIG, SPOT_RAD, measure_frames, pointing_batch, recognition_failure,
                     smear_loss_mag, star_biases, trail_rate)
from .radiation import RadiationGrid, SolarEvent
from .sky import CELLS_PER_EDGE, Sky


class Outcome(enum.IntEnum):
    """Why a star-tracker frame has, or has not, an attitude (the reason codes of physics.md §6)."""

    OK = 0
    RATE_TOO_HIGH = 1  #: the trail rate is above the hard ceiling
    OUTAGE = 2  #: inside an outage window the operator set
    NO_STARS = 3  #: fewer than 3 catalogue stars among the objects sent to recognition
    RECOGNITION_FAILURE = 4  #: enough stars, but recognition failed
    BUFFER_OVERFLOW = 5  #: proton hits (and the stars) filled the video buffer before the frame was read
    EXCLUSION = 6  #: the Sun, the Moon or the Earth's limb is too close to the boresight
    INVALID_TRUTH = 7  #: the true attitude given to the model was not a finite quaternion
    NO_ORBIT = 8  #: orbit.source follow: no orbit state at the frame time (the attitude cannot be turned into orbital)

    @property
    def reason(self) -> str:
        """The reason code as /diagnostics and reports say it (``no_stars``, …)."""
        return self.name.lower()

    @property
    def phrase(self) -> str:
        """The reason in words, for a /diagnostics message ("no stars", "scheduled outage", …)."""
        return "scheduled outage" if self is Outcome.OUTAGE else self.reason.replace("_", " ")


#: The reasons a frame gives no attitude, in the order a frame is checked for them (the first that holds is
#: reported): an override, then the frame cannot be taken, then what it saw.
REASON_ORDER = (Outcome.INVALID_TRUTH, Outcome.OUTAGE, Outcome.RATE_TOO_HIGH, Outcome.EXCLUSION,
                Outcome.BUFFER_OVERFLOW, Outcome.NO_STARS, Outcome.RECOGNITION_FAILURE)

#: Area of the CCD's sensitive surface (512 × 16 µm square), cm² [D from the format A].
CCD_AREA_CM2 = 0.671
#: Protons from 35° to 90° off the CCD normal pass the side shielding (thesis l. 944) [T].
SIDE_WINDOW_RAD = math.radians(35.0)
#: CCD element, µm [T]; ionisation thickness of the CCD, µm [A: ≥ 19 µm from l. 962].
PIXEL_UM, ION_THICKNESS_UM = 16.0, 20.0
#: Longest hit track, pixels [T: areas of 1 to 40–50 elements]; point hits cover 1–4 pixels [A].
MAX_TRACK_PX, POINT_PX = 50.0, (1.0, 4.0)
#: Hit integral brightness, log-uniform between these ADC counts [T range, l. 841].
HIT_ADC = (30.0, 5000.0)
#: The brightness scale: an Hp = 6.5 star gives 500 ADC in a 2 s exposure at rest [A].
STAR_ADC, STAR_ADC_HP, STAR_ADC_EXPOSURE_S = 500.0, 6.5, 2.0
#: Pixels above threshold of a registered star (a 3 × 3 defocused image) [T].
STAR_PX = 9
#: Most hits whose brightness is drawn per frame: only the brightest can reach the K sent to recognition.
MAX_RANKED_HITS = 50
#: Above this altitude solar protons reach everywhere (physics.md §6 item 7: "in GEO everywhere"; the geomagnetic
#: shielding that the L-shell cut-off describes is a low-orbit one) [A].
FULL_ACCESS_ALTITUDE_M = 20000e3

# Streams of the keyed draws (kernel.measure_frames; keys: the frame time, then the star or hit): a star's rank
# scatter and centroid noise u, v in a frame 0–2, a star's bias u, v for good 3–4, a frame's recognition dice, side
# and lens hit counts and hit footprint 5–8, the hits' brightness ranks 9.
#: The Sun and the Moon are computed once a minute of the clock (keyed by the minute: the same for any frame of it):
#: in a minute the Moon moves ≈ 33″ and the Sun ≈ 2.5″ across the sky, against exclusion angles of degrees.
BODY_STEP_S = 60.0


@dataclass(frozen=True)
class TrackerParameters:
    """Configuration of the star tracker; SI and radians (physics.md §6 gives each default and its tag).

    Timing: ``exposure_s`` (the time tag is its middle), ``frame_period_s`` (the frame grid's step: the orbit is
    computed ahead on it for frames that come one at a time).
    Sky and detection: ``field_width_rad`` (square side), ``catalogue_stars`` (the on-board catalogue: the
    brightest of the sky), ``sky_stars`` (the stars the sky holds), ``detection_margin_mag`` (m_det0 = the
    catalogue's faintest Hp + this). Recognition: ``max_objects`` (K), ``rank_scatter_mag`` (σ_rank),
    ``geometry_failure_3`` (p3), ``geometry_failure_scale`` (n_s), ``false_object_failure`` (p_conf).
    Accuracy: ``centroid_error_rad`` (σ per star and axis), ``bias_fraction`` (the share of its variance that
    stays with the star). Rate: ``max_rate_rad_s`` (hard ceiling of the trail rate). Protons: ``trapped``
    (``"max"``, ``"min"`` or ``"off"``), ``solar_event`` (None: none), ``access_min_l`` (L where solar
    protons reach), ``buffer_bytes``, ``bytes_per_pixel``. Exclusion: ``sun_exclusion_rad``,
    ``moon_exclusion_rad``, ``earth_limb_exclusion_rad``, ``stray_light_at_edge`` (stray light / sky
    background at an exclusion edge; falls as θ⁻³ to 0 at twice the edge). ``boresight_body``: the boresight
    in the body. ``outages``: (start_s, end_s) windows of simulation time with no output. ``ideal``: true
    attitude on every frame outside an outage.
    """

    exposure_s: float = 0.75
    frame_period_s: float = 1.0
    field_width_rad: float = math.radians(7.81)
    catalogue_stars: int = 8350
    sky_stars: int = 26547
    detection_margin_mag: float = 1.0
    max_objects: int = 10
    rank_scatter_mag: float = 0.3
    geometry_failure_3: float = 0.3
    geometry_failure_scale: float = 1.5
    false_object_failure: float = 0.01
    centroid_error_rad: float = 9.5 * ARCSEC_RAD
    bias_fraction: float = 0.5
    max_rate_rad_s: float = 600.0 * ARCSEC_RAD
    trapped: str = "max"
    solar_event: SolarEvent | None = None
    access_min_l: float = 7.1
    buffer_bytes: int = 4096
    bytes_per_pixel: int = 4
    sun_exclusion_rad: float = math.radians(30.0)
    moon_exclusion_rad: float = math.radians(10.0)
    earth_limb_exclusion_rad: float = math.radians(20.0)
    stray_light_at_edge: float = 1.0
    boresight_body: tuple = (0.0, 0.0, 1.0)
    outages: tuple = field(default_factory=tuple)
    ideal: bool = False

    def __post_init__(self) -> None:
        def check(name, low, high):
            value = getattr(self, name)
            if not (low <= value <= high):
                raise ValueError(f"{name} = {value} is outside the allowed range {low} … {high}")

        check("exposure_s", 1e-3, 100.0)
        check("frame_period_s", 1e-3, 1000.0)
        check("field_width_rad", math.radians(0.5), math.radians(40.0))
        check("catalogue_stars", 3, 26547)
        check("sky_stars", self.catalogue_stars, 26547)
        check("detection_margin_mag", -3.0, 5.0)
        check("max_objects", 3, 100)
        for name in ("geometry_failure_3", "false_object_failure", "bias_fraction"):
            check(name, 0.0, 1.0)
        check("geometry_failure_scale", 0.01, 100.0)
        check("rank_scatter_mag", 0.0, 10.0)
        check("centroid_error_rad", 0.0, math.radians(1.0))
        check("max_rate_rad_s", 1e-6, math.radians(10.0))
        check("access_min_l", 1.0, 1000.0)
        check("buffer_bytes", 64, 1 << 30)
        check("bytes_per_pixel", 1, 64)
        for name in ("sun_exclusion_rad", "moon_exclusion_rad", "earth_limb_exclusion_rad"):
            check(name, 0.0, math.pi / 2.0)
        check("stray_light_at_edge", 0.0, 1e6)
        if self.trapped not in ("max", "min", "off"):
            raise ValueError(f"trapped = {self.trapped!r} is not one of 'max', 'min', 'off'")
        axis = np.asarray(self.boresight_body, float)
        if axis.shape != (3,) or not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-9:
            raise ValueError(f"boresight_body = {self.boresight_body} must be a finite, non-zero 3-vector")
        for window in self.outages:
            if len(window) != 2 or not (math.isfinite(window[0]) and math.isfinite(window[1])) or window[1] < window[0]:
                raise ValueError(f"outage window {window} must be (start_s, end_s) with start ≤ end")


def optimal_exposure_s(rate_rad_s: float) -> float:
    """t_opt = d·ρ/(f·ω): past it a longer exposure adds no signal-to-noise (thesis (1.3), l. 402), s."""
    return SPOT_RAD / rate_rad_s


@lru_cache(maxsize=1)
def hit_footprint_moments() -> tuple[tuple[float, float], tuple[float, float]]:
    """Mean and variance of a hit's pixels through the side window and through the lens, px.

    Incidence θ off the CCD normal drawn ∝ sin θ cos θ over each window; a hit is a point of 1–4 pixels
    (uniform) plus a track of t_ion·tan θ / p pixels, at most 50 in all (physics.md §6 item 6).
    """
    moments = []
    for low, high in ((SIDE_WINDOW_RAD, math.pi / 2.0), (0.0, SIDE_WINDOW_RAD)):
        theta = np.linspace(low, high, 20001)[:-1] + (high - low) / 40000.0
        weight = np.sin(theta) * np.cos(theta)
        weight /= weight.sum()
        track = np.minimum(ION_THICKNESS_UM * np.tan(theta) / PIXEL_UM, MAX_TRACK_PX)
        point_mean = 0.5 * (POINT_PX[0] + POINT_PX[1])
        point_var = (POINT_PX[1] - POINT_PX[0]) ** 2 / 12.0
        pixels = np.minimum(point_mean + track, MAX_TRACK_PX)
        mean = float((weight * pixels).sum())
        moments.append((mean, float((weight * (pixels - mean) ** 2).sum()) + point_var))
    return moments[0], moments[1]


def geodetic_from_ecef(r_ecef_m):
    """Geodetic latitude, longitude (rad) and height above GRS80 (m) of ``(3, N)`` Earth-fixed positions (Bowring)."""
    x, y, z = r_ecef_m
    a, b = GRS80.a_m, GRS80.b_m
    e2, ep2 = 1.0 - (b / a) ** 2, (a / b) ** 2 - 1.0
    p = np.hypot(x, y)
    theta = np.arctan2(z * a, p * b)
    latitude = np.arctan2(z + ep2 * b * np.sin(theta) ** 3, p - e2 * a * np.cos(theta) ** 3)
    sin_lat = np.sin(latitude)
    n = a / np.sqrt(1.0 - e2 * sin_lat ** 2)
    height = p * np.cos(latitude) + z * sin_lat - a * a / n
    return latitude, np.arctan2(y, x), height


def _frame_about(boresight) -> np.ndarray:
    """Rotation matrix whose third column is the unit boresight (columns: cross, cross, boresight)."""
    z = np.asarray(boresight, float) / np.linalg.norm(boresight)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


@dataclass(frozen=True)
class FrameMeasurement:
    """The tracker's frames, measured: ``(N,)`` per frame unless said.

    ``q_measured`` (4, N) orbital → body (x, y, z, w), NaN without output;
    ``outcome`` :class:`Outcome` codes (int8); ``stars`` catalogue stars
    registered in the field; ``hits`` proton hits on the CCD; ``used``
    catalogue stars among the objects sent to recognition.
    """

    q_measured: np.ndarray
    outcome: np.ndarray
    stars: np.ndarray
    hits: np.ndarray
    used: np.ndarray


@dataclass(frozen=True)
class OrbitEnvironment:
    """What frames see of the orbit alone, ``(…, N)`` per frame: the spacecraft position ``(3, N)`` m and the
    orbital axes ``(3, 3, N)`` in ECI, the orbital frame's rate ``(N,)`` rad/s, the mean proton hits through the
    side window and the lens ``(N,)``, and the Sun and the Moon ``(3, N)`` m (geocentric, ECI)."""

    position_eci_m: np.ndarray
    orbital_axes_eci: np.ndarray
    frame_rate_rad_s: np.ndarray
    side_hits_mean: np.ndarray
    lens_hits_mean: np.ndarray
    sun_eci_m: np.ndarray
    moon_eci_m: np.ndarray

    @property
    def arrays(self) -> tuple:
        """The arrays in the order the frame kernel takes them (orbital axes, frame rate, position, Sun, Moon, mean
        hits through the side window and the lens), C-contiguous."""
        return tuple(np.ascontiguousarray(a, float) for a in (
            self.orbital_axes_eci, self.frame_rate_rad_s, self.position_eci_m, self.sun_eci_m, self.moon_eci_m,
            self.side_hits_mean, self.lens_hits_mean))


#: Frames of orbit computed ahead at a time for frames that come one by one (a node's), on the frame grid: ten
#: minutes at a frame a second, ≈ 1 ms once (the orbit, the flux grid, the Sun and the Moon on arrays: ≈ 1.4 µs a
#: frame, against ≈ 8 µs a frame for blocks of 64; benchmarks/bench_tracker.py).
ORBIT_BLOCK_FRAMES = 600


@dataclass(frozen=True)
class Pointing:
    """Where frames look and how they move: the tracker axes in ECI ``(3, 3, N)`` (columns: the two
    focal-plane axes, the boresight), the spacecraft position ``(3, N)`` m ECI, and the inertial rate across
    and about the boresight ``(N,)`` rad/s."""

    axes_eci: np.ndarray
    position_eci_m: np.ndarray
    cross_rate_rad_s: np.ndarray
    about_rate_rad_s: np.ndarray


class StarTracker:
    """Star-tracker frames from the true attitude on an orbit (seeded; draws keyed by the frame time).

    Args:
        parameters: the model's configuration.
        orbit: anything with ``state_eci(t_s)`` → position m and velocity m/s ``(3, N)`` ECI of date.
        clock_epoch: the UTC instant at simulation time 0 (the Sun, the Moon, the Earth's rotation, the date of
            the sky and of a solar event).
        seed: seed of the draws.
        sky, radiation: already loaded tables (default: the shipped ones, loaded here).
        orbit_known_ahead: whether the orbit can be asked for times ahead of the frames (a node's frames then take
            the orbit from a block computed ahead; False: an orbit followed from odometry, asked frame by frame).
    """

    def __init__(self, parameters: TrackerParameters, orbit, clock_epoch: Epoch, seed: int = 0, *,
                 sky: Sky | None = None, radiation: RadiationGrid | None = None, orbit_known_ahead: bool = True):
        self.parameters = p = parameters
        self.orbit_known_ahead = orbit_known_ahead
        self.orbit, self.clock_epoch = orbit, clock_epoch
        self.seed = np.array([seed_hash(seed)], np.uint64)
        self.tracker_axes = _frame_about(p.boresight_body)
        self._bodies = {}  # minute of the clock → (Sun, Moon) geocentric positions, m (a few kept)
        self._ahead = {}  # frame time → its column in the block of the orbit computed ahead (_ahead_block)
        self._ahead_block = None
        if not p.ideal:
            self.sky = sky if sky is not None else Sky(float(clock_epoch.julian_date_tt(0.0)))
            need_grid = p.trapped != "off" or p.solar_event is not None
            self.radiation = radiation if radiation is not None or not need_grid else RadiationGrid()
            hp = self.sky.hp_mag
            if len(self.sky) < p.sky_stars:
                raise ValueError(f"sky_stars = {p.sky_stars} is more than the {len(self.sky)} stars of the sky table")
            self.catalogue_limit_mag = float(hp[p.catalogue_stars - 1])
            self.hip = self.sky.hip
            self._cells = self.sky.index(p.field_width_rad / 2.0)  # built now, not at the first frame
            self._bias = star_biases(self.seed[0], self.hip)  # each star's centroid bias: keyed by the star alone
            (side_px, side_var), (lens_px, lens_var) = hit_footprint_moments()
            constants = dict(
                exposure_s=p.exposure_s, half_width_rad=p.field_width_rad / 2.0, catalogue_stars=p.catalogue_stars,
                sky_stars=p.sky_stars, detection_limit_at_rest_mag=self.catalogue_limit_mag + p.detection_margin_mag,
                max_objects=p.max_objects, rank_scatter_mag=p.rank_scatter_mag,
                geometry_failure_3=p.geometry_failure_3, geometry_failure_scale=p.geometry_failure_scale,
                false_object_failure=p.false_object_failure, centroid_error_rad=p.centroid_error_rad,
                bias_fraction=p.bias_fraction, max_rate_rad_s=p.max_rate_rad_s, buffer_bytes=p.buffer_bytes,
                bytes_per_pixel=p.bytes_per_pixel, sun_exclusion_rad=p.sun_exclusion_rad,
                moon_exclusion_rad=p.moon_exclusion_rad, earth_limb_exclusion_rad=p.earth_limb_exclusion_rad,
                stray_light_at_edge=p.stray_light_at_edge, earth_radius_m=GRS80.a_m,
                side_hit_pixels_mean=side_px, side_hit_pixels_variance=side_var, lens_hit_pixels_mean=lens_px,
                lens_hit_pixels_variance=lens_var, hit_adc_low=HIT_ADC[0], hit_adc_high=HIT_ADC[1],
                star_adc_scale=STAR_ADC * p.exposure_s / STAR_ADC_EXPOSURE_S, star_adc_hp=STAR_ADC_HP,
                star_pixels=STAR_PX, max_ranked_hits=MAX_RANKED_HITS)
            self._config = np.array([float(constants[name]) for name in CONFIG])
            # The kernel's arguments that are the same for every frame, in its order.
            self._tables = (self.tracker_axes, self._config, self.seed, self.sky.direction_eci, hp, self.hip,
                            self._bias[0], self._bias[1], *self._cells, CELLS_PER_EDGE)

    # -- the stages ------------------------------------------------------------------------------

    def orbit_environment(self, t_s: np.ndarray) -> OrbitEnvironment:
        """What the frames at ``t_s`` ``(N,)`` see of the orbit alone (:class:`OrbitEnvironment`)."""
        position, velocity = self.orbit.state_eci(t_s)
        position, velocity = np.reshape(position, (3, -1)), np.reshape(velocity, (3, -1))
        orbital = orbital_frame_from_state(position, velocity)  # (3, 3, N)
        # The orbital frame turns about its Y at |r × v|/r² (the mean motion on a circular orbit).
        frame_rate = np.linalg.norm(np.cross(position, velocity, axis=0), axis=0) / np.sum(position ** 2, axis=0)
        side, lens = self.proton_hits_mean(t_s, position)
        sun, moon = self.sun_and_moon_eci_m(t_s)
        return OrbitEnvironment(position, orbital, frame_rate, side, lens, sun, moon)

    def _environment(self, t_s: np.ndarray) -> tuple[tuple, np.ndarray]:
        """:meth:`orbit_environment` for the frames at ``t_s`` (its :attr:`~OrbitEnvironment.arrays`), and each
        frame's column in it ``(N,)``: frames that
        come one or two at a time (a node's) take theirs from a block computed ahead on the frame grid (the same
        arithmetic on the same times, so the same numbers: a frame time off the block — a frame grid restarted or
        carried past several frames at once — computes a new block)."""
        if t_s.size > 2 or not self.orbit_known_ahead:
            return self.orbit_environment(t_s).arrays, np.arange(t_s.size)
        found = [self._ahead.get(t) for t in t_s.tolist()]
        if None in found:
            start, step = float(t_s[0]), self.parameters.frame_period_s
            times = [start]
            for _ in range(ORBIT_BLOCK_FRAMES - 1):
                times.append(times[-1] + step)  # the grid's own steps: a frame's time is the last one's + period
            self._ahead_block = self.orbit_environment(np.array(times)).arrays
            self._ahead = {time: k for k, time in enumerate(times)}
            found = [self._ahead.get(t) for t in t_s.tolist()]
            if None in found:
                return self.orbit_environment(t_s).arrays, np.arange(t_s.size)
        return self._ahead_block, np.array(found, np.int64)

    def pointing(self, q_true: np.ndarray, relative_rate_rad_s: np.ndarray, environment: OrbitEnvironment) -> Pointing:
        """Where the frames look (true attitude ``(4, N)``, body rate relative to the orbital frame ``(3, N)`` in
        orbital components, rad/s) on the orbit of ``environment``: the frame kernel's first stage
        (:func:`~pmv_ros.physics.star_tracker.kernel.pointing_batch`)."""
        axes, cross, about = pointing_batch(np.ascontiguousarray(q_true, float), self.tracker_axes,
                                            np.ascontiguousarray(environment.orbital_axes_eci),
                                            np.ascontiguousarray(np.reshape(relative_rate_rad_s, (3, -1)), float),
                                            np.ascontiguousarray(environment.frame_rate_rad_s, float))
        return Pointing(axes, environment.position_eci_m, cross, about)

    def sun_and_moon_eci_m(self, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Geocentric Sun and Moon positions ``(3, N)`` m at the start of each frame's minute (:data:`BODY_STEP_S`)."""
        minute = np.floor(np.asarray(t_s, float) / BODY_STEP_S).astype(np.int64)
        known = self._bodies
        if minute.size == 1 and int(minute[0]) in known:
            sun, moon = known[int(minute[0])]
            return sun, moon
        unique, index = np.unique(minute, return_inverse=True)
        jd_tt = self.clock_epoch.julian_date_tt(unique * BODY_STEP_S)
        sun, moon = sun_position_eci_m(jd_tt).reshape(3, -1), moon_position_eci_m(jd_tt).reshape(3, -1)
        if unique.size <= 2:  # a node's frames: keep the last few minutes
            for k, key in enumerate(unique.tolist()):
                known[key] = (sun[:, k:k + 1], moon[:, k:k + 1])
            while len(known) > 4:
                known.pop(next(iter(known)))
        return sun[:, index], moon[:, index]

    def proton_hits_mean(self, t_s: np.ndarray, position_eci_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean proton hits a frame through the side window and through the lens ``(N,)`` each (items 6, 7).

        N = A·t_exp·[J(>45 MeV)/4·cos²35° + J(>100 MeV)/4·sin²35°] for the trapped flux J (omnidirectional);
        a solar event adds A·t_exp·π·I(>45 MeV)·cos²35° through the side where L ≥ ``access_min_l`` (and
        everywhere above :data:`FULL_ACCESS_ALTITUDE_M`).
        """
        p = self.parameters
        side = np.zeros(t_s.shape)
        lens = np.zeros(t_s.shape)
        if p.trapped == "off" and p.solar_event is None:
            return side, lens
        ecef = _eci_to_ecef(position_eci_m, self.clock_epoch.earth_rotation_angle(t_s))
        latitude, longitude, height = geodetic_from_ecef(ecef)
        flux45, flux100, shell = self.radiation.environment(latitude, longitude, height,
                                                            "min" if p.trapped == "min" else "max")
        open_side, open_lens = math.cos(SIDE_WINDOW_RAD) ** 2, math.sin(SIDE_WINDOW_RAD) ** 2
        scale = CCD_AREA_CM2 * p.exposure_s
        if p.trapped != "off":
            side = side + scale * flux45 / 4.0 * open_side
            lens = lens + scale * flux100 / 4.0 * open_lens
        if p.solar_event is not None:
            intensity = p.solar_event.intensity_pfu(self.clock_epoch.seconds_since_j2000(t_s))
            reached = (shell >= p.access_min_l) | (height >= FULL_ACCESS_ALTITUDE_M)
            side = side + np.where(reached, scale * math.pi * intensity * open_side, 0.0)
        return side, lens

    def ground_track_deg(self, t_s) -> tuple[np.ndarray, np.ndarray]:
        """Geodetic latitude and longitude (deg, ``(N,)`` each) under the spacecraft at ``t_s`` ``(N,)`` s, on the
        orbit and clock the frames are measured on (where reports draw the frames)."""
        t = np.atleast_1d(np.asarray(t_s, float))
        position, _ = self.orbit.state_eci(t)
        latitude, longitude, _ = geodetic_from_ecef(_eci_to_ecef(np.reshape(position, (3, -1)),
                                                                 self.clock_epoch.earth_rotation_angle(t)))
        return np.degrees(latitude), np.degrees(longitude)

    # -- the frame ----------------------------------------------------------------------------

    def in_outage(self, t_s):
        """True where ``t_s`` lies inside an outage window, ``(N,)``."""
        t = np.asarray(t_s, float)
        inside = np.zeros(t.shape, bool)
        for start, end in self.parameters.outages:
            inside |= (t >= start) & (t < end)
        return inside

    def measure(self, t_s, q_orbital_to_body, relative_rate_rad_s) -> FrameMeasurement:
        """The frames at ``t_s`` ``(N,)`` s (mid-exposure), true attitude ``(4, N)`` (x, y, z, w), body rate
        relative to the orbital frame ``(3, N)`` rad/s in orbital components: :class:`FrameMeasurement`.

        What the frames see of the orbit comes from numpy (:meth:`_environment`: a node's frames from a block
        computed ahead); the frames themselves from the compiled kernel
        (:func:`~pmv_ros.physics.star_tracker.kernel.measure_frames`).
        """
        p = self.parameters
        t = np.asarray(t_s, float).reshape(-1)
        n_frames = t.size
        q_true = np.asarray(q_orbital_to_body, float).reshape(4, n_frames)
        outage = self.in_outage(t)
        if p.ideal:
            norm = np.sqrt((q_true * q_true).sum(axis=0))
            finite = np.isfinite(norm) & (norm > 0.5)
            q = np.where(finite, q_true / np.where(finite, norm, 1.0), np.nan)
            outcome = np.where(finite, np.where(outage, Outcome.OUTAGE.value, Outcome.OK.value),
                               Outcome.INVALID_TRUTH.value).astype(np.int8)
            q[:, outcome != Outcome.OK.value] = np.nan
            return FrameMeasurement(q, outcome, *(np.zeros(n_frames, np.int64) for _ in range(3)))
        environment, column = self._environment(t)
        q_measured, outcome, counts = np.empty((4, n_frames)), np.empty(n_frames, np.int8), \
            np.empty((3, n_frames), np.int64)
        stars, hits, used = counts
        measure_frames(t, np.ascontiguousarray(q_true), outage,
                       np.ascontiguousarray(np.asarray(relative_rate_rad_s, float).reshape(3, n_frames)), column,
                       *environment, *self._tables, q_measured, outcome, stars, hits, used)
        return FrameMeasurement(q_measured, outcome, stars, hits, used)


def rotation_matrices(q_xyzw: np.ndarray) -> np.ndarray:
    """The rotation matrices ``(3, 3, N)`` of unit quaternions (x, y, z, w) ``(4, N)`` (scipy's ``as_matrix``:
    for q orbital → body, the columns are the body's axes in orbital components)."""
    x, y, z, w = q_xyzw
    return np.array([[1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)],
                     [2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)],
                     [2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)]])


def _eci_to_ecef(vectors: np.ndarray, angle_rad) -> np.ndarray:
    """Rotate ``(3, N)`` ECI vectors by the Earth rotation angle ``(N,)`` into the Earth-fixed frame."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([c * vectors[0] + s * vectors[1], -s * vectors[0] + c * vectors[1], vectors[2]])
