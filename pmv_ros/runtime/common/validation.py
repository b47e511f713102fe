"""What every node checks on its inputs before anything touches its state — one home, no ROS.

Everything a message from the network carries is checked here, with one
reason code per way of being wrong (:class:`Rejection`); the nodes and the
monitor core only call these checks, count the reasons and say so on
``/diagnostics``. Nothing here raises for a bad sample.

* **Values** — :func:`check_quaternion` (finite, norm within
  :data:`QUATERNION_NORM_TOLERANCE` of 1, then normalised),
  :func:`check_angles` (finite or NaN where the stream allows "lost", and
  within a plausibility bound: a horizon sensor that reads 1e308 rad has not
  measured anything), :func:`check_orbit_state` (a bound Earth orbit: radius
  and speed within bounds, negative specific energy, a perigee above the
  Earth's surface), :func:`check_odometry` (a whole orbit/odometry message:
  frames, state, stamp). The bounds are
  :class:`InputBounds`, set from node parameters.
* **Stamps** — :class:`StampCheck`, one per stream: NaN/Inf, zero or negative,
  in the future of the node clock, duplicate, backwards, and faster than the
  stream may be (a flood that stamps faster than the stream's rate is
  limited, and a flood can never move the stream's "latest" forward by more
  than the future tolerance).
* **Clock jumps** — :class:`JumpDetector` (the rule is in its docstring): a
  jump is acted on once, and only when the next observation confirms it; a
  single forged ``/clock`` message or stamp that time then contradicts is an
  outlier, counted, and changes nothing.
* **Frames** — :func:`check_frame`, and :class:`FrameCheck` for a stream:
  a message stamped in another frame than its stream's is refused, and the
  refusal says what was expected (once on the log, on ``/diagnostics``
  while it lasts).
* **/clock** — :class:`ClockCheck`: whether a ``/clock`` message may set a
  node's time.
* **Files** — :func:`pmv_ros.storage.files.read_text_file`: a regular text
  file of bounded size, opened without blocking; errors never echo the file's
  contents.

Where else an input is guarded: which publisher a node listens to is
:mod:`.source_lock`; how refused requests are counted and said is
:mod:`.refusals`.

Times are seconds (float), angles radians, lengths metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import NamedTuple

from ...physics.constants import EARTH_MEAN_RADIUS_M, GM_EARTH_M3_S2
from .source_lock import DEFAULT_TIMEOUT_S, SourceLock

#: | |q| − 1 | up to which a quaternion is normalised (and counted); beyond it, rejected.
#: Rounding in a float32 stack or a serialiser leaves ~1e-7; 1e-2 admits a stack that
#: normalises now and then, and refuses anything that is not an attitude.
QUATERNION_NORM_TOLERANCE = 0.01

#: |q| − 1 below which a quaternion is taken as unit already (rounding of a float64 normalisation).
UNIT_ROUNDING = 1e-9


class Rejection(str, Enum):
    """Why an incoming sample was dropped (the value is the counter suffix: ``rejected_<stream>_<value>``)."""

    NON_FINITE = "non_finite"                # NaN/Inf stamp or value
    ZERO_STAMP = "zero_stamp"                # stamp 0 (unset header) or negative
    FUTURE_STAMP = "future_stamp"            # later than the node clock + future tolerance
    DUPLICATE = "duplicate"                  # same stamp as the previous sample of the stream
    BACKWARDS = "backwards"                  # earlier than the previous sample, by less than the jump threshold
    UNCONFIRMED_JUMP = "unconfirmed_jump"    # a jump back that the next sample has not confirmed (yet)
    TOO_FAST = "too_fast"                    # stamped closer to the previous sample than the stream's rate allows
    BAD_QUATERNION = "bad_quaternion"        # norm further than the tolerance from 1 (or zero)
    IMPLAUSIBLE_ANGLE = "implausible_angle"  # |roll| or |pitch| beyond the plausibility bound
    IMPLAUSIBLE_ORBIT = "implausible_orbit"  # radius, speed, energy or perigee not those of a bound Earth orbit
    OTHER_SOURCE = "other_source"            # from a second publisher on the stream (source_lock.SourceLock)
    WRONG_FRAME = "wrong_frame"              # stamped in another frame than the stream's (check_frame)


#: Largest |sensor − truth| per axis that can be a residual of one spacecraft, rad (6°). The PMV reads roll and
#: pitch only within ≈ 3° (beyond, a chord pair loses the horizon and its angle is NaN, never a number), so a valid
#: reading and the truth of the same spacecraft differ by at most ≈ 3° plus the truth's own ≈ 3°; a sensor good to
#: a few arcminutes against a truth 10° away (≈ 600′) is a forged or foreign truth, refused and counted
#: (``skipped_implausible_residual``), never added to the statistics.
MAX_PLAUSIBLE_RESIDUAL_RAD = math.radians(6.0)

#: The stamp reasons, in the order :class:`StampCheck` tries them.
STAMP_REJECTIONS = (Rejection.NON_FINITE, Rejection.ZERO_STAMP, Rejection.FUTURE_STAMP, Rejection.DUPLICATE,
                    Rejection.BACKWARDS, Rejection.UNCONFIRMED_JUMP, Rejection.TOO_FAST)
#: Reasons a truth message is dropped (the /diagnostics keys are rejected_truth_<reason>).
TRUTH_REJECTIONS = STAMP_REJECTIONS + (Rejection.BAD_QUATERNION,)


def check_frame(frame_id: str, expected: str) -> Rejection | None:
    """WRONG_FRAME unless a message is stamped in the frame its stream is defined in (None then).

    interfaces.md "Frames": an input is checked against its expected frame —
    an inertial quaternion on /attitude/truth, whose attitude is relative to
    the orbital frame, would otherwise be taken as an orbital attitude.
    Frame ids compare exactly (tf2 does too): no prefix is guessed.
    """
    return None if frame_id == expected else Rejection.WRONG_FRAME


#: Characters of a refused frame id quoted in a log line or a status (a frame id comes from the network: a longer
#: one, or one with characters a terminal would act on, is shown as a truncated Python literal).
SHOWN_FRAME_CHARS = 64


def shown_frame(frame_id) -> str:
    """A frame id from a message as a log line or a status may quote it: as it is when it is a short printable
    ASCII string, else a Python literal of its first :data:`SHOWN_FRAME_CHARS` characters (``…`` if cut)."""
    text = frame_id if isinstance(frame_id, str) else str(frame_id)
    if text and len(text) <= SHOWN_FRAME_CHARS and text.isascii() and text.isprintable() and " " not in text:
        return text
    return repr(text[:SHOWN_FRAME_CHARS]) + ("…" if len(text) > SHOWN_FRAME_CHARS else "")


class FrameCheck:
    """:func:`check_frame` for one input, with the words a refusal is said in: what was expected, what came.

    ``what`` names the input for people (``"star-tracker truth"``). The first
    refusal gives one log line (:meth:`take_log_line`: once for the check's
    life, however many messages follow); while messages keep being refused —
    until one is stamped in the expected frame again — :attr:`problem` is the
    phrase for ``/diagnostics``. Memory is bounded: a count and the last
    refused frame id, shortened (:func:`shown_frame`).
    """

    __slots__ = ("what", "expected", "refused", "_got", "_said", "_line")

    def __init__(self, what: str, expected: str) -> None:
        self.what, self.expected = what, expected
        self.refused = 0  # messages refused for their frame
        self._got = None  # the frame id of the latest refused message while refusals last (None: the last was taken)
        self._said = False
        self._line = None

    def check(self, frame_id: str) -> Rejection | None:
        """WRONG_FRAME (counted, and remembered for the words) unless ``frame_id`` is the expected frame."""
        rejection = check_frame(frame_id, self.expected)
        if rejection is None:
            self._got = None
            return None
        self.refused += 1
        self._got = shown_frame(frame_id)
        if not self._said:
            self._said = True
            self._line = (f"{self.words()}: each such message is dropped (counted on /diagnostics); "
                          "this is said once")
        return rejection

    def words(self) -> str:
        """``<what> refused: expected <frame>, got <frame>`` of the latest refusal ('' while none lasts)."""
        if self._got is None:
            return ""
        return f"{self.what} refused: expected {self.expected}, got {self._got}"

    @property
    def problem(self) -> str | None:
        """The /diagnostics phrase while the input's messages are being refused for their frame, else None."""
        if self._got is None:
            return None
        return f"{self.words()} ({self.refused} refused)"

    def take_log_line(self) -> str | None:
        """The line to log about the first refusal, once (None before it and ever after)."""
        line, self._line = self._line, None
        return line


# ----------------------------------------------------------------------------------- values

@dataclass(frozen=True)
class InputBounds:
    """Plausibility bounds on input values (SI, rad); ValueError for bounds that admit nothing.

    Args:
        max_abs_angle_rad: largest |roll|, |pitch| a sensor sample may have (default 30°:
            the PMV sees the horizon on all four chords only within a few degrees; beyond
            30° it sees none, so a reading out there is not a measurement).
        min_orbit_radius_m, max_orbit_radius_m: geocentric radius of the spacecraft
            (default 100 km above the mean radius … 50,000 km, beyond geostationary).
        min_orbit_speed_m_s, max_orbit_speed_m_s: inertial speed (default 0.5 … 11.2 km/s;
            the energy check refuses an unbound state inside these as well).
    """

    max_abs_angle_rad: float = math.radians(30.0)
    min_orbit_radius_m: float = EARTH_MEAN_RADIUS_M + 100e3
    max_orbit_radius_m: float = 5.0e7
    min_orbit_speed_m_s: float = 500.0
    max_orbit_speed_m_s: float = 11200.0

    def __post_init__(self) -> None:
        if not (0.0 < self.max_abs_angle_rad <= math.pi):
            raise ValueError(f"max_abs_angle_rad = {self.max_abs_angle_rad} is outside the allowed range (0, π]")
        if not (EARTH_MEAN_RADIUS_M <= self.min_orbit_radius_m < self.max_orbit_radius_m <= 1e9):
            raise ValueError(f"orbit radius bounds [{self.min_orbit_radius_m}, {self.max_orbit_radius_m}] m must "
                             f"satisfy {EARTH_MEAN_RADIUS_M:g} ≤ min < max ≤ 1e9")
        if not (0.0 <= self.min_orbit_speed_m_s < self.max_orbit_speed_m_s <= 1e5):
            raise ValueError(f"orbit speed bounds [{self.min_orbit_speed_m_s}, {self.max_orbit_speed_m_s}] m/s "
                             "must satisfy 0 ≤ min < max ≤ 1e5")


def check_quaternion(q_xyzw, tolerance: float = QUATERNION_NORM_TOLERANCE):
    """Validate a quaternion (x, y, z, w): (unit quaternion as a tuple of 4 floats or None, Rejection or None,
    normalised).

    Non-finite components give NON_FINITE; a norm further than ``tolerance``
    from 1 (a zero quaternion, a component of 1e308 whose square overflows)
    gives BAD_QUATERNION; otherwise the quaternion is returned normalised, and
    ``normalised`` says whether that changed more than rounding. The norm
    bound is the components' plausibility bound: an accepted quaternion has
    every |component| ≤ 1 + ``tolerance``.
    """
    try:
        components = [float(c) for c in q_xyzw]
    except (TypeError, ValueError):
        return None, Rejection.NON_FINITE, False
    if len(components) != 4 or not all(map(math.isfinite, components)):
        return None, Rejection.NON_FINITE, False
    # hypot does not overflow for finite components: 1e308 gives a norm of 1e308, refused below.
    norm = math.hypot(*components)
    if not abs(norm - 1.0) <= tolerance:
        return None, Rejection.BAD_QUATERNION, False
    # Float by float (a message's one quaternion: no array to build): each quotient as an array's would be.
    x, y, z, w = components
    return (x / norm, y / norm, z / norm, w / norm), None, abs(norm - 1.0) > UNIT_ROUNDING


def check_angles(roll_rad: float, pitch_rad: float, max_abs_rad: float, *, allow_nan: bool) -> Rejection | None:
    """Why a (roll, pitch) pair is not a plausible measurement, or None.

    ``allow_nan``: NaN is the sensor's word for "this chord pair lost the
    horizon" and passes; ±Inf never does. A magnitude beyond ``max_abs_rad``
    is IMPLAUSIBLE_ANGLE.
    """
    for value in (roll_rad, pitch_rad):
        if math.isnan(value):
            if not allow_nan:
                return Rejection.NON_FINITE
        elif math.isinf(value):
            return Rejection.NON_FINITE
        elif abs(value) > max_abs_rad:
            return Rejection.IMPLAUSIBLE_ANGLE
    return None


def check_orbit_state(position_m, velocity_m_s, bounds: InputBounds) -> Rejection | None:
    """Why an ECI position (m) and velocity (m/s) are not a state of a bound Earth orbit, or None.

    Radius and speed within ``bounds``, negative specific energy v²/2 − GM/r
    (a hyperbolic state is no orbit the sensor flies), and a perigee above the
    Earth's mean radius: a state whose conic passes through the Earth is a fall,
    not an orbit, and the limit of that is zero angular momentum (r ∥ v), where
    the orbit plane, the node and the argument of latitude do not exist.
    """
    try:
        rx, ry, rz = map(float, position_m)  # map, not a generator: this runs for every odometry message
        vx, vy, vz = map(float, velocity_m_s)
    except (TypeError, ValueError):
        return Rejection.NON_FINITE
    if not all(map(math.isfinite, (rx, ry, rz, vx, vy, vz))):
        return Rejection.NON_FINITE
    radius, speed = math.hypot(rx, ry, rz), math.hypot(vx, vy, vz)
    if not (bounds.min_orbit_radius_m <= radius <= bounds.max_orbit_radius_m):
        return Rejection.IMPLAUSIBLE_ORBIT
    if not (bounds.min_orbit_speed_m_s <= speed <= bounds.max_orbit_speed_m_s):
        return Rejection.IMPLAUSIBLE_ORBIT
    energy = 0.5 * speed * speed - GM_EARTH_M3_S2 / radius
    if energy >= 0.0:
        return Rejection.IMPLAUSIBLE_ORBIT
    # Perigee r_p = p / (1 + e), p = h²/GM, e² = 1 + 2εh²/GM² (clamped: rounding near a circle).
    h = math.hypot(ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx)
    semi_latus = h * h / GM_EARTH_M3_S2
    eccentricity = math.sqrt(max(0.0, 1.0 + 2.0 * energy * semi_latus / GM_EARTH_M3_S2))
    if not semi_latus / (1.0 + eccentricity) > EARTH_MEAN_RADIUS_M:
        return Rejection.IMPLAUSIBLE_ORBIT
    return None


def check_odometry(frame_id: str, child_frame_id: str, state, eci: str, orbital: str, bounds: InputBounds,
                   stamps: StampCheck, now_s: float | None) -> tuple[Rejection | None, bool]:
    """(why one orbit/odometry message is refused or None, whether its stamp confirmed a clock jump back).

    The sensor's and the tracker's one check of ``orbit.source`` follow: the pose in the ``eci`` frame, the twist
    in the ``orbital`` frame (:func:`check_frame`), ``state`` (stamp s, position m, velocity m/s; None when the
    message was unreadable: an orientation that is no rotation, a bad stamp) a bound orbit
    (:func:`check_orbit_state`), and only then the stamp through the stream's ``stamps`` at ``now_s``. After a
    confirmed jump the caller starts its orbit history over.
    """
    rejection = check_frame(frame_id, eci) or check_frame(child_frame_id, orbital)
    if rejection is None:
        if state is None:
            return Rejection.NON_FINITE, False
        rejection = check_orbit_state(state[1], state[2], bounds)
    if rejection is not None:
        return rejection, False
    return stamps.check(state[0], now_s)


# ------------------------------------------------------------------------------ clock jumps

class Jump(str, Enum):
    """What :meth:`JumpDetector.observe` made of one time observation."""

    NONE = "none"                    # on the current timeline
    SUSPECTED = "suspected"          # off the timeline by more than the threshold: waiting for the next one
    CONFIRMED_BACK = "back"          # the timeline went back (a restart): act on it now, once
    CONFIRMED_FORWARD = "forward"    # the timeline went forward by more than the threshold (a gap)
    OUTLIER = "outlier"              # the suspected jump was contradicted: a single bad observation


class JumpDetector:
    """Tell a real clock jump from a single bad time observation; act on a jump once.

    Rule: an observation more than ``threshold_s`` before the latest time on
    the current timeline, or more than ``forward_threshold_s`` after it, is a
    *suspected* jump and is not used. The next observation decides:

    * on the new timeline — later than the suspect, and on the same side of
      the old timeline — the jump is *confirmed*: reported once
      (CONFIRMED_BACK or CONFIRMED_FORWARD) and the new timeline is current;
    * back on the old timeline — the suspected jump was an *outlier* (a
      forged ``/clock``, a mis-stamped message): OUTLIER, and nothing else
      changes;
    * anywhere else (or equal to the suspect: a clock that has not ticked
      since) — it is the suspect now, and the one after decides.

    So a single forged jump costs one observation and never a reset; a real
    restart costs one observation and exactly one reset.

    Args:
        threshold_s: how far back an observation must be to be a jump, s.
        forward_threshold_s: how far ahead an observation must be to be a jump, s (a
            node clock: a forged ``/clock`` a year ahead must not become "now");
            None: time may leap forward freely (stamps after a gap — the future
            check bounds them).
    """

    def __init__(self, threshold_s: float, *, forward_threshold_s: float | None = None) -> None:
        for value in (threshold_s, threshold_s if forward_threshold_s is None else forward_threshold_s):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"a jump threshold of {value} s is not a positive number of seconds")
        self.threshold_s = float(threshold_s)
        self.forward_threshold_s = math.inf if forward_threshold_s is None else float(forward_threshold_s)
        self.latest_s: float | None = None
        self.suspect_s: float | None = None

    def reset(self) -> None:
        """Forget the timeline (the next observation starts a new one)."""
        self.latest_s = None
        self.suspect_s = None

    def observe(self, t_s: float) -> Jump:
        """Classify one finite time observation, s, and move the timeline (see the class docstring)."""
        latest, threshold = self.latest_s, self.threshold_s
        if latest is None:
            self.latest_s = t_s
            return Jump.NONE
        suspect = self.suspect_s
        if latest - threshold <= t_s <= latest + self.forward_threshold_s:
            self.latest_s = max(latest, t_s)
            if suspect is None:
                return Jump.NONE
            self.suspect_s = None
            return Jump.OUTLIER
        if suspect is not None and t_s > suspect and (t_s < latest) == (suspect < latest):
            self.suspect_s, self.latest_s = None, t_s
            return Jump.CONFIRMED_BACK if t_s < latest else Jump.CONFIRMED_FORWARD
        self.suspect_s = t_s  # a new suspect, or the same one again (a clock that has not ticked)
        return Jump.SUSPECTED


# ------------------------------------------------------------------------------------ stamps

class StampCheck:
    """The stamp checks of one input stream, with its clock-jump rule and its rate limit.

    Args:
        jump_threshold_s: a stamp more than this before the latest one is a clock jump
            (confirmed by the next stamp, see :class:`JumpDetector`); less is BACKWARDS.
        future_tolerance_s: a stamp later than ``now_s`` + this is FUTURE_STAMP.
        min_interval_s: a stamp closer than this after the latest accepted one is
            TOO_FAST (0: no limit) — a flood stamping faster than the stream's rate is
            thinned to that rate, and cannot run the stream's clock ahead.
    """

    def __init__(self, jump_threshold_s: float, future_tolerance_s: float, min_interval_s: float = 0.0) -> None:
        if not (math.isfinite(future_tolerance_s) and future_tolerance_s > 0.0):
            raise ValueError(f"future_tolerance_s = {future_tolerance_s} must be a positive number of seconds")
        if not (math.isfinite(min_interval_s) and 0.0 <= min_interval_s < jump_threshold_s):
            raise ValueError(f"min_interval_s = {min_interval_s} must be in [0, jump threshold "
                             f"{jump_threshold_s:g} s)")
        self.jumps = JumpDetector(jump_threshold_s)
        self.future_tolerance_s = float(future_tolerance_s)
        self.min_interval_s = float(min_interval_s)
        self.outliers = 0  # suspected jumps that the next stamp contradicted

    @property
    def latest_s(self) -> float | None:
        """The latest accepted stamp, s (None: none since the start or the last reset)."""
        return self.jumps.latest_s

    def reconfigured(self, jump_threshold_s: float, future_tolerance_s: float,
                     min_interval_s: float = 0.0) -> "StampCheck":
        """A check with new limits on the same timeline (a parameter change; ValueError for bad limits)."""
        check = StampCheck(jump_threshold_s, future_tolerance_s, min_interval_s)
        check.jumps.latest_s, check.outliers = self.jumps.latest_s, self.outliers
        return check

    def reset(self) -> None:
        """Start a new timeline: the next valid stamp is accepted whatever it is."""
        self.jumps.reset()

    def check(self, t_s: float, now_s: float | None = None) -> tuple[Rejection | None, bool]:
        """(why ``t_s`` is rejected or None, whether it confirmed a jump back).

        A confirmed jump back is accepted as the first stamp of the new
        timeline; the caller resets what depends on the old one — once.
        ``now_s``: the node clock, s (None or non-finite: no future check).
        """
        if not math.isfinite(t_s):
            return Rejection.NON_FINITE, False
        if t_s <= 0.0:
            return Rejection.ZERO_STAMP, False
        if now_s is not None and math.isfinite(now_s) and t_s > now_s + self.future_tolerance_s:
            return Rejection.FUTURE_STAMP, False
        jumps = self.jumps
        latest = jumps.latest_s
        if latest is None or t_s >= latest - jumps.threshold_s:
            # On the current timeline: the ordinary checks, then the detector (which may call a
            # pending jump an outlier now that this stamp contradicts it).
            if latest is not None:
                if t_s == latest:
                    return Rejection.DUPLICATE, False
                if t_s < latest:
                    return Rejection.BACKWARDS, False
                if t_s - latest < self.min_interval_s:
                    return Rejection.TOO_FAST, False
            if jumps.observe(t_s) is Jump.OUTLIER:
                self.outliers += 1
            return None, False
        if jumps.observe(t_s) is Jump.SUSPECTED:
            return Rejection.UNCONFIRMED_JUMP, False
        return None, True


class QuaternionSample(NamedTuple):
    """What :func:`check_quaternion_sample` made of one stamped quaternion."""

    q_xyzw: tuple | None  #: the unit quaternion (x, y, z, w), None if rejected
    rejection: Rejection | None
    jumped: bool  #: a confirmed clock jump: the caller starts a new timeline (once)
    outliers: int  #: suspected jumps this stamp contradicted (counted ``clock_outliers``)
    normalised: bool


def check_quaternion_sample(stamps: StampCheck, t_s: float, q_xyzw, now_s: float | None) -> QuaternionSample:
    """One stamped attitude quaternion through every check a truth stream gets: the quaternion, then its stamp.

    The stamp is checked (and ``stamps`` advanced) only for a valid quaternion,
    so a bad message never moves a stream's timeline.
    """
    q, rejection, normalised = check_quaternion(q_xyzw)
    jumped, outliers = False, 0
    if rejection is None:
        before = stamps.outliers
        rejection, jumped = stamps.check(t_s, now_s)
        outliers = stamps.outliers - before
    return QuaternionSample(q if rejection is None else None, rejection, jumped, outliers, normalised)


# ------------------------------------------------------------------------------------ /clock

#: Why a ``/clock`` message was not allowed to set a node's time (counted as ``rejected_clock_<reason>``).
CLOCK_REJECTIONS = ("malformed", "negative", "other_source", "unconfirmed_jump")

_INT32_MAX = 2**31 - 1


class ClockCheck:
    """Whether one ``/clock`` message may set a node's time; counts per reason.

    Rule, in order: the time must be well formed (``sec`` an int32,
    ``nanosec`` in [0, 1e9)) — else ``malformed``; not negative — else
    ``negative`` (rclpy's time source raises on it and the node would stop);
    from the first publisher heard (:class:`~.source_lock.SourceLock`, silence measured on
    the caller's wall clock) — else ``other_source``: a second ``/clock``
    publisher is one more source on a stream; and on the current timeline or
    a jump the next message confirms (:class:`JumpDetector`: back by more
    than ``jump_back_s`` or ahead by more than ``jump_ahead_s``) — else
    ``unconfirmed_jump``: a single forged time costs one message, never a
    reset, and a real restart of the simulation costs one message.

    Args:
        jump_back_s, jump_ahead_s: the jump thresholds, s.
        source_timeout_s: wall-clock silence after which the locked publisher is given up, s.
    """

    def __init__(self, jump_back_s: float, jump_ahead_s: float, source_timeout_s: float = DEFAULT_TIMEOUT_S) -> None:
        self._jumps = JumpDetector(jump_back_s, forward_threshold_s=jump_ahead_s)
        self.sources = SourceLock(source_timeout_s)
        self.counts = dict.fromkeys(CLOCK_REJECTIONS, 0)

    def admit(self, sec, nanosec, *, wall_s: float, gid=None, sequence: int | None = None) -> str | None:
        """None if the message may set the time, else the reason it may not (and it is counted)."""
        reason = None
        if (not isinstance(sec, int) or not isinstance(nanosec, int) or isinstance(sec, bool)
                or not 0 <= nanosec < 1_000_000_000 or not -_INT32_MAX - 1 <= sec <= _INT32_MAX):
            reason = "malformed"
        elif sec < 0:
            reason = "negative"
        else:
            t_s = sec + nanosec * 1e-9
            if not self.sources.admit(wall_s, gid=gid, sequence=sequence, stamp_s=t_s):
                reason = "other_source"
            elif self._jumps.observe(t_s) is Jump.SUSPECTED:
                reason = "unconfirmed_jump"
        if reason is not None:
            self.counts[reason] += 1
        return reason
