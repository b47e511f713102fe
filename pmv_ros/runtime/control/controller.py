"""attitude_controller_node's work without ROS: a rigid body held nadir-pointing by a PD loop on the PMV.

:class:`ControllerRuntime` integrates the plant (:class:`pmv_ros.physics.rigid_body.RigidBody`) on a
grid of control steps, ``control.rate_hz``, and at each step:

1. takes the newest ``pmv/attitude`` measurement (roll, pitch, REP-103) as the roll and pitch error —
   held between measurements, and per axis while the pair that measures it has lost the horizon
   (NaN: counted ``measurement_<axis>_held``); before the first measurement an axis has none and no
   proportional torque;
2. takes yaw, which the PMV does not observe (physics.md §1), as ``control.yaw`` says: ``truth`` — closed on
   the true yaw, as a star tracker or gyrocompass would give it; ``free`` — no yaw torque at all;
3. takes the body rate relative to the orbital frame from an ideal gyro (the plant's true rate);
4. applies τ = −K_p·e − K_d·rate (:func:`pmv_ros.physics.rigid_body.pd_torque`) plus the disturbance
   (a constant torque and one at the orbital frequency), held over the step (zero-order hold);
5. publishes the attitude at the step's end (``attitude/truth``, the ``orbital → base_link`` transform) and
   adds it to the true pointing error (:class:`~pmv_ros.runtime.control.pointing.PointingStatistics`,
   after the loop's settling time; not for a host that takes the pointing at its own sample times).

Who advances the plant: a host that steps it (:meth:`ControllerRuntime.step_to`: the campaign's flight before
each sensor sample; :meth:`ControllerRuntime.step_at_next_measurement`: the in-process pipeline, so the step
that the sample's measurement decides is taken as soon as that measurement arrives, in the same pass of the
executor) or the node's timer (:meth:`ControllerRuntime.tick`: every step up to the node clock). A step's attitude
is published when the plant reaches it, stamped with its time: a following sensor measures at its own sample
times between them (slerp).

Inputs are checked as every node checks them (:mod:`pmv_ros.runtime.common.validation`): the frame (the
sensor's: ``frames.sensor``), the stamp (duplicates, backwards, future, too fast; a jump back by more than
``clock_jump_s`` confirmed by the next stamp is a new timeline) and the angles (±Inf or beyond
``input.max_abs_angle_deg`` refused; NaN is "lost" and passes). A refused message changes nothing and is
counted ``rejected_measurement_<reason>`` on ``/diagnostics``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

from ...physics.attitude import quaternion_from_roll_pitch_yaw, true_roll_pitch, true_yaw
from ...physics.constants import ARCMIN_RAD
from ...physics.orbit.two_body import circular_mean_motion_rad_s
from ...physics.rigid_body import PdGains, RigidBody, pd_torque, settling_time_s
from ..common.frames import Frames
from ..common.records import HealthAt, HealthSummary, Level, LogLine
from ..common.validation import Jump, JumpDetector, Rejection, StampCheck, check_angles, check_frame
from .pointing import PointingStatistics

#: The loop must be much slower than its sampling: f_n ≤ control.rate_hz / this (ω_n·T ≤ 0.31 rad, where
#: the zero-order hold's half-period lag costs < 9° of phase and one Runge–Kutta step per period is exact to
#: ≈ 1e-5 of the motion).
MIN_STEPS_PER_NATURAL_PERIOD = 20

#: Control steps one host call or tick may integrate at most (10 min at 10 Hz): a clock that leapt further
#: is a new timeline, not a burst of integration.
MAX_STEPS_PER_CALL = 6000

#: Stamps this close are the same instant, s (float stamps of integer nanoseconds).
SAME_INSTANT_S = 1e-9


class TruthPublication(NamedTuple):
    """The plant's state at a control step: the attitude to publish (``attitude/truth``, /tf) and its rate."""

    t_s: float
    q_xyzw: tuple
    rate_rad_s: tuple


@dataclass
class ControllerOutput:
    """What one input, step or tick makes the controller say: ``published`` in order, and ``log`` lines."""

    published: list = field(default_factory=list)  #: TruthPublication and HealthAt items
    log: list = field(default_factory=list)  #: LogLine items

    @property
    def truth(self) -> list[TruthPublication]:
        """The plant states of :attr:`published`, in order."""
        return [item for item in self.published if isinstance(item, TruthPublication)]


@dataclass(frozen=True)
class LoopSettings:
    """What the controller derives from its parameters (rad, s, N·m)."""

    gains: PdGains
    yaw_closed: bool
    period_s: float
    constant_torque_nm: tuple
    orbital_torque_nm: tuple
    measurement_timeout_s: float
    max_abs_angle_rad: float
    diagnostics_period_s: float

    @classmethod
    def from_values(cls, values: dict) -> "LoopSettings":
        """From attitude_controller_node parameter values; ValueError naming a value the ranges cannot check."""
        rate_hz, bandwidth_hz = values["control.rate_hz"], values["control.bandwidth_hz"]
        if bandwidth_hz * MIN_STEPS_PER_NATURAL_PERIOD > rate_hz:
            raise ValueError(f"control.bandwidth_hz = {bandwidth_hz:g} Hz is above control.rate_hz / "
                             f"{MIN_STEPS_PER_NATURAL_PERIOD} = {rate_hz / MIN_STEPS_PER_NATURAL_PERIOD:g} Hz: "
                             "a loop that fast needs a faster control rate")
        return cls(gains=PdGains(bandwidth_hz, values["control.damping_ratio"], _three(values, "body.inertia_kg_m2")),
                   yaw_closed=values["control.yaw"] == "truth", period_s=1.0 / rate_hz,
                   constant_torque_nm=_three(values, "disturbance.constant_torque_nm"),
                   orbital_torque_nm=_three(values, "disturbance.orbital_torque_nm"),
                   measurement_timeout_s=values["control.measurement_timeout_s"],
                   max_abs_angle_rad=math.radians(values["input.max_abs_angle_deg"]),
                   diagnostics_period_s=values["diagnostics_period_s"])

    @property
    def settling_time_s(self) -> float:
        """The loop's settling time (≈ 2 %), s: the start-up transient the pointing statistics leave out."""
        return settling_time_s(self.gains.bandwidth_hz, self.gains.damping_ratio)


def _three(values: dict, name: str) -> tuple:
    """A parameter that must hold three numbers (body X, Y, Z), as a tuple; ValueError naming it otherwise."""
    value = values[name]
    if len(value) != 3:
        raise ValueError(f"{name} has {len(value)} elements: give three (body X, Y, Z)")
    return tuple(float(v) for v in value)


def plant_of(values: dict) -> RigidBody:
    """The rigid body of attitude_controller_node's parameters (ValueError naming an impossible inertia)."""
    try:
        return RigidBody(_three(values, "body.inertia_kg_m2"),
                         circular_mean_motion_rad_s(values["orbit.altitude_km"] * 1e3),
                         values["disturbance.gravity_gradient"])
    except ValueError as error:
        raise ValueError(f"body.inertia_kg_m2: {error}") from None


class _Axis:
    """One measured axis (roll or pitch): the value the loop holds and when it was measured."""

    __slots__ = ("value_rad", "measured_s", "held")

    def __init__(self) -> None:
        self.value_rad, self.measured_s, self.held = 0.0, None, 0


def _no_counters() -> dict:
    return {}


class ControllerRuntime:
    """The plant and its PD loop without ROS: measurements in, the plant's attitude and health out.

    Args:
        values: attitude_controller_node parameter values
            (:data:`pmv_ros.runtime.common.assembly.CONTROLLER_PARAMS`).
        start_s: the clock at the start, s: the plant's first state (``body.initial_attitude_arcmin``, at rest
            in the orbital frame) is at this time and is not published (a stamp of 0 is no stamp).
        source_counters: ``() -> dict`` of the node's input-source counters, merged into every report.
        keep_pointing: keep the true pointing statistics of every control step (:attr:`pointing`); a host that
            takes the pointing at its own sample times (the campaign's flight) passes False, and
            :attr:`pointing` is None.

    Raises ValueError for a combination of values the parameter ranges cannot check.
    """

    def __init__(self, values: dict, *, start_s: float, source_counters: Callable[[], dict] = _no_counters,
                 keep_pointing: bool = True) -> None:
        self.frames = Frames.from_values(values)
        self.body = plant_of(values)
        self.settings = LoopSettings.from_values(values)
        self.values = values
        self._source_counters = source_counters
        roll, pitch, yaw = (v * ARCMIN_RAD for v in _three(values, "body.initial_attitude_arcmin"))
        self.q = tuple(float(c) for c in quaternion_from_roll_pitch_yaw(roll, pitch, yaw))
        self.rate = (0.0, 0.0, 0.0)
        self.origin_s = self.time_s = float(start_s)  # the grid's origin and the plant's time
        self._steps = 0  # control steps since the origin: the plant's time is origin + steps × period
        self.pointing = self.new_pointing() if keep_pointing else None
        self._roll, self._pitch = _Axis(), _Axis()
        self._stamps = StampCheck(values["clock_jump_s"], values["future_tolerance_s"],
                                  1.0 / values["input.max_rate_hz"])
        self._clock = self._clock_detector(values)
        self.counters = {"measurements": 0, "steps": 0}
        self._reported_s = None
        self._deferred_s = None  # a step_to waiting for the next measurement (step_at_next_measurement)
        self._out = ControllerOutput()

    def new_pointing(self) -> PointingStatistics:
        """Empty true pointing statistics of this loop: harmonics of its orbit, the transient until the loop's
        settling time after the start left out (:attr:`pointing`'s; a host that keeps its own makes them here)."""
        return PointingStatistics(2.0 * math.pi / self.body.mean_motion_rad_s,
                                  self.origin_s + self.settings.settling_time_s)

    # -- parameters ---------------------------------------------------------------------------

    def reconfigure(self, values: dict) -> None:
        """New gains, disturbance, timeouts (the plant's state is kept); ValueError changes nothing."""
        settings = LoopSettings.from_values(values)
        self._stamps = self._stamps.reconfigured(values["clock_jump_s"], values["future_tolerance_s"],
                                                 1.0 / values["input.max_rate_hz"])
        self._clock = self._clock_detector(values, self._clock)
        self.settings, self.values = settings, values

    def _clock_detector(self, values: dict, previous: JumpDetector | None = None) -> JumpDetector:
        """The node clock's jump rule: back by more than ``clock_jump_s``, or ahead by more than the steps one
        tick may integrate (a leap is a new timeline, not a burst of integration); ``previous``'s timeline kept."""
        detector = JumpDetector(values["clock_jump_s"],
                                forward_threshold_s=MAX_STEPS_PER_CALL / values["control.rate_hz"])
        if previous is not None:
            detector.latest_s = previous.latest_s
        return detector

    # -- inputs ---------------------------------------------------------------------------------

    def add_measurement(self, frame_id: str, stamp_s: float | None, roll_rad, pitch_rad,
                        clock_s: float | None) -> ControllerOutput | None:
        """One ``pmv/attitude`` message (``stamp_s`` None: unreadable): keep its angles or count why not."""
        rejection = check_frame(frame_id, self.frames.sensor)
        if rejection is None and stamp_s is None:
            rejection = Rejection.ZERO_STAMP
        if rejection is None:
            rejection = check_angles(roll_rad, pitch_rad, self.settings.max_abs_angle_rad, allow_nan=True)
        if rejection is None:
            rejection, jumped = self._stamps.check(stamp_s, clock_s)
            if jumped:
                self._count("clock_jumps")
        if rejection is not None:
            self._count(f"rejected_measurement_{rejection.value}")
            return None
        self.counters["measurements"] += 1
        for axis, value in ((self._roll, roll_rad), (self._pitch, pitch_rad)):
            if math.isnan(value):
                axis.held += 1
            else:
                axis.value_rad, axis.measured_s = value, stamp_s
        return None if self._deferred_s is None else self.step_to(self._deferred_s)

    # -- the plant ------------------------------------------------------------------------------

    def step_at_next_measurement(self, t_s: float) -> None:
        """:meth:`step_to` ``t_s`` as soon as the next measurement is taken (its output is then
        :meth:`add_measurement`'s): a host that has just had the sensor measure hands it the next sample's time,
        and the plant reaches it with that measurement in hand. Until then :attr:`deferred_s` says so; a
        :meth:`step_to` in between (no measurement came) takes its place."""
        self._deferred_s = float(t_s)

    @property
    def deferred_s(self) -> float | None:
        """The time a step waits to reach until the next measurement (:meth:`step_at_next_measurement`), or None."""
        return self._deferred_s

    def step_to(self, t_s: float) -> ControllerOutput:
        """Advance the plant by whole control steps until its time reaches ``t_s`` (within 1 ns), publishing
        each step's state. A host calls this before it needs the attitude at ``t_s``."""
        self._deferred_s = None
        steps = math.ceil((t_s - self.time_s) / self.settings.period_s - SAME_INSTANT_S / self.settings.period_s)
        if steps > MAX_STEPS_PER_CALL:  # a leap, not a stretch to integrate: a new timeline here
            self._restart_at(t_s)
        else:
            for _ in range(max(steps, 0)):
                self._step()
        return self._take()

    def tick(self, now_s: float) -> ControllerOutput:
        """The node's timer: every control step up to the node clock ``now_s``. A clock that jumps (back or
        forward by more than ``clock_jump_s``, confirmed by the next tick) restarts the grid there; the
        plant keeps its state."""
        jump = self._clock.observe(now_s)
        if jump in (Jump.CONFIRMED_BACK, Jump.CONFIRMED_FORWARD):
            self._restart_at(now_s)
        elif jump is Jump.OUTLIER:
            self._count("clock_outliers")
        elif jump is not Jump.SUSPECTED:
            whole = math.floor((now_s - self.time_s) / self.settings.period_s + SAME_INSTANT_S)
            return self.step_to(self.time_s + whole * self.settings.period_s) if whole > 0 else self._take()
        return self._take()

    def _restart_at(self, t_s: float) -> None:
        self._count("clock_jumps")
        self.origin_s, self.time_s, self._steps = t_s, t_s, 0
        self._out.log.append(LogLine("info", f"clock jumped to t = {t_s:.3f} s: the plant's grid restarts there "
                                             "(its state is kept)"))

    def _step(self) -> None:
        settings, body = self.settings, self.body
        t0 = self.time_s
        roll, pitch, yaw = self._errors(t0)
        control = pd_torque(settings.gains, (roll, pitch, yaw), self.rate)
        if not settings.yaw_closed:
            control = (control[0], control[1], 0.0)
        cyclic = math.sin(body.mean_motion_rad_s * (t0 - self.origin_s))
        (dx, dy, dz), (ax, ay, az) = settings.constant_torque_nm, settings.orbital_torque_nm
        torque = (control[0] + dx + ax * cyclic, control[1] + dy + ay * cyclic, control[2] + dz + az * cyclic)
        self.q, self.rate = body.step(self.q, self.rate, torque, settings.period_s)
        self._steps += 1
        self.time_s = t_s = self.origin_s + self._steps * settings.period_s
        self.counters["steps"] += 1
        if self.pointing is not None:
            self.pointing.add(t_s, self.q)
        self._out.published.append(TruthPublication(t_s, self.q, self.rate))
        self._report(t_s)

    def _errors(self, t_s: float) -> tuple[float, float, float]:
        """The roll, pitch and yaw errors the law acts on at ``t_s``, rad: the held measurements (0 before the
        first) and the true yaw (0 with ``control.yaw`` free: no yaw torque is made of it)."""
        yaw = true_yaw(self.q) if self.settings.yaw_closed else 0.0
        return self._roll.value_rad, self._pitch.value_rad, yaw

    # -- output ---------------------------------------------------------------------------------

    def _count(self, key: str) -> None:
        self.counters[key] = self.counters.get(key, 0) + 1

    def stale_axes(self, t_s: float) -> list[str]:
        """The measured axes not measured within ``control.measurement_timeout_s`` before ``t_s`` (never yet
        measured counts once the timeout has passed since the start)."""
        timeout = self.settings.measurement_timeout_s
        return [name for name, axis in (("roll", self._roll), ("pitch", self._pitch))
                if t_s - (self.origin_s if axis.measured_s is None else axis.measured_s) > timeout]

    def _report(self, t_s: float) -> None:
        """A /diagnostics report every ``diagnostics_period_s`` of plant time."""
        if self._reported_s is not None and 0.0 <= t_s - self._reported_s < self.settings.diagnostics_period_s:
            return
        self._reported_s = t_s
        self._out.published.append(HealthAt(t_s, self.health(t_s)))

    def health(self, t_s: float) -> HealthSummary:
        """The controller's status at ``t_s``: OK, or WARN while an axis is stale or messages are refused."""
        stale = self.stale_axes(t_s)
        refused = sorted(k for k in self.counters if k.startswith("rejected_"))
        problems = ([f"no pmv/attitude {' or '.join(stale)} for more than "
                     f"{self.settings.measurement_timeout_s:g} s (holding the last)"] if stale else []) + \
                   (["rejected pmv/attitude messages"] if refused else [])
        roll, pitch = true_roll_pitch(self.q)  # the latest true roll and pitch
        values = {**self.counters, "measurement_roll_held": self._roll.held, "measurement_pitch_held": self._pitch.held,
                  "pointing_roll_arcmin": roll / ARCMIN_RAD, "pointing_pitch_arcmin": pitch / ARCMIN_RAD,
                  "bandwidth_hz": self.settings.gains.bandwidth_hz, **self._source_counters()}
        if problems:
            return HealthSummary(Level.WARN, "; ".join(problems), values)
        return HealthSummary(Level.OK, "closed on pmv/attitude", values)

    def _take(self) -> ControllerOutput:
        out, self._out = self._out, ControllerOutput()
        return out
