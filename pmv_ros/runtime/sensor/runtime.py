"""sensor_node's work without ROS: inputs and ticks in, the samples and health to publish out, in order.

:class:`SensorRuntime` owns everything the sensor node derives from its
parameters and its inputs: the models and the sample stream
(:class:`~pmv_ros.runtime.sensor.sample_stream.SampleStream`), the real-time sample
grid, the fast-time clock, the followed truth
(:class:`~pmv_ros.runtime.common.truth_buffer.TruthBuffer`) and orbit
(:class:`~pmv_ros.runtime.common.orbit_buffer.FollowedOrbit`) with their stamp
checks, and the health counters
(:class:`~pmv_ros.runtime.sensor.health.SensorHealth`). The node hands it
plain values read from its messages and its clock; each call returns a
:class:`SensorOutput`: what to publish, in publication order (a
:class:`SamplePublication` per sample, a :class:`HealthAt` per
``/diagnostics`` report), and what to log.

A chord without a horizon, without a crossing, or with the Sun or the Moon
near its arc is invalid: its point is NaN and so is its pair's angle (roll
for ±Y, pitch for ±X); ``/diagnostics`` names the chord and the cause.

Follow mode (``attitude.source: follow``; README "Follow mode"): the node
never publishes ``/attitude/truth``; the runtime measures with the attitude
at its own sample time (:class:`pmv_ros.runtime.common.truth_buffer.TruthBuffer`:
slerp between truth samples, the last body rate for
``attitude.extrapolation_periods`` truth periods past the newest, and up to
``attitude.extrapolation_s`` to bridge a late truth sample, counted
``truth_bridged``), stamps the output with that time, and publishes nothing
from stale truth: the stale state is an ERROR on ``/diagnostics`` at once
and logged once. Bad truth (non-finite, far-from-unit, zero, future,
duplicate, backward, too-fast stamps: :mod:`pmv_ros.runtime.common.validation`) is
dropped and counted; a truth clock that jumps back by more than
``attitude.follow_timeout_s`` starts a new timeline once the next stamp
confirms it. Truth stamped in another frame than the orbital one
(``frames.*``) is refused (``rejected_truth_wrong_frame``). The node follows
only the first publisher of ``/attitude/truth`` heard; a second one is an
ERROR on ``/diagnostics`` (:class:`pmv_ros.runtime.common.validation.SourceLock`).

The graph is the node's: the runtime asks it through two callables given
at construction (``graph_problems``: how many others publish the truth the
own attitude model publishes, and the second sources of the inputs;
``source_counters``: the input counters of the node's source locks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np

from ...physics.orbit.tle import OrbitPropagationError
from ..common.assembly import READ_CORRECTION, build_models, build_orbit, orbit_bounds, read_correction
from .estimator_output import EstimatorOrientation, estimator_orientation, variance_from_rms_arcmin
from ..common.frames import Frames
from ..common.orbit_buffer import FollowedOrbit, OrbitAt
from ..common.records import HealthAt, HealthSummary, Level  # HealthAt: the sensor's ``horizon`` status
from .sample_stream import SampleGrid, SampleStream, SensorSample, fast_time_block
from .health import SensorHealth, truth_source_warnings
from ..common.truth_buffer import PendingSamples, TruthAt, TruthBuffer
from ..common.validation import Jump, JumpDetector, Rejection, StampCheck, check_frame, check_odometry, \
    check_quaternion_sample


class SamplePublication(NamedTuple):
    """One sample to publish: the sensor's output and its orientation for estimators (``pmv/attitude_imu``)."""

    sample: SensorSample
    imu: EstimatorOrientation


class LogLine(NamedTuple):
    """A line for the node's log: ``level`` is ``"info"`` or ``"error"``."""

    level: str
    text: str


@dataclass(slots=True)
class SensorOutput:
    """What one input or tick makes the sensor say: ``published`` in order, and ``log`` lines."""

    published: list = field(default_factory=list)  #: SamplePublication and HealthAt items (a tuple when empty)
    log: list = field(default_factory=list)  #: LogLine items (a tuple when empty)

    @property
    def samples(self) -> list[SensorSample]:
        """The samples of :attr:`published`, in order."""
        return [item.sample for item in self.published if isinstance(item, SamplePublication)]

    @property
    def health(self) -> list[HealthAt]:
        """The ``/diagnostics`` reports of :attr:`published`, in order."""
        return [item for item in self.published if isinstance(item, HealthAt)]


#: Where a followed attitude can come from (TruthAt.usable), and two of them, looked up once (an enum member's
#: lookup is a descriptor call, a sample's follow path asks several).
_USABLE_TRUTH = frozenset(source for source in TruthAt if source.usable)
_STALE, _BRIDGED = TruthAt.STALE, TruthAt.BRIDGED

#: What a call returns when it says nothing (a fresh one is made only when something is said; never appended to).
_NOTHING = SensorOutput((), ())


def _no_graph_problems() -> tuple[int, tuple]:
    return 0, ()


class SensorRuntime:
    """The PMV sensor without ROS: orbit + attitude → samples and health.

    Args:
        values: sensor_node parameter values (:data:`pmv_ros.runtime.common.assembly.SENSOR_PARAMS`).
        clock_epoch_s: the node clock at the start, s (the orbit's epoch and the sample grid's origin).
        correction: the brightness-correction table (read once by the caller), or
            :data:`~pmv_ros.runtime.common.assembly.READ_CORRECTION`: read here, once, after the orbit and the
            epoch are checked (refused, they read no file and compute no table).
        stepped: fast time is stepped by a caller (``pmv simulate``), not by a paced timer.
        truth_topic, odometry_topic: the node's resolved input names (its health names them).
        graph_problems: ``() -> (other_truth_publishers, source_errors)``: how many publish /attitude/truth
            besides the own attitude model (0 when following: a second source is then one of the source errors,
            a tuple of phrases), asked at most every ``diagnostics_period_s`` of sample time.
        source_counters: ``() -> dict`` of the node's input-source counters, merged into every report.

    Raises ValueError for a combination of values the parameter ranges cannot check.
    """

    def __init__(self, values: dict, *, clock_epoch_s: float, correction, stepped: bool = False,
                 truth_topic: str = "/attitude/truth",
                 odometry_topic: str = "/orbit/odometry",
                 graph_problems: Callable[[], tuple[int, tuple]] = _no_graph_problems,
                 source_counters: Callable[[], dict] = dict) -> None:
        self.frames = Frames.from_values(values)
        self.clock_epoch_s = clock_epoch_s
        self.stepped = stepped
        if correction is READ_CORRECTION:
            build_orbit(values, clock_epoch_s=clock_epoch_s)
            correction = read_correction(values)
        self._correction = correction
        self._graph_problems, self._source_counters = graph_problems, source_counters
        self.stream = self.grid = self.truth = self._truth_stamps = None
        self.values = values
        self.reconfigure(values)
        self.following = values["attitude.source"] == "follow"
        self.orbit_following = values["orbit.source"] == "follow"
        self.health = SensorHealth(truth_topic, odometry_topic)
        self._truth_state = None  # follow mode: where the last tick's attitude came from
        self._stale_logged = False  # follow mode: the stale truth was logged and has not come back since
        self._orbit_problem = None  # orbit.source follow: (OrbitAt, message) while sample times have no orbit
        self._orbit_error = None  # an element set's orbit that SGP4 could not propagate: no output from then on
        self._graph_warnings, self._source_errors, self._graph_checked_s = (), (), None
        # Real time on a /clock someone else publishes: a tick on a single forged time is skipped, not measured.
        self._tick_clock = JumpDetector(1.0, forward_threshold_s=10.0)
        if self.orbit_following:
            timeout = values["orbit.follow_timeout_s"]
            self._odometry_stamps = StampCheck(timeout, timeout, 1.0 / values["input.max_rate_hz"])
        self._waiting = PendingSamples()  # follow mode, real time: due sample times waiting for truth
        self.sim_time_s = values["sim.start_time_s"]
        self._host_time_s = None  # the last sample time a host stepped the sensor to (step_to)
        self._out = SensorOutput()

    # -- parameters ---------------------------------------------------------------------------

    def reconfigure(self, values: dict) -> None:
        """Build the models, the stream and the input buffers from ``values`` (the inputs so far are kept).

        In fast time the orbit's epoch stays the start of the clock already running.
        """
        if values["sim.fast_time"]:
            values = dict(values, **{"sim.start_time_s": self.values["sim.start_time_s"]})
        orbit, profile, model = build_models(values, clock_epoch_s=self.clock_epoch_s, correction=self._correction)
        model.prepare()  # a sensor is ready when built: its first tick does not build the chain's tables
        previous_orbit = self.stream.orbit if self.stream is not None else None
        if isinstance(orbit, FollowedOrbit) and isinstance(previous_orbit, FollowedOrbit):  # it keeps its states
            orbit.buffer.take_states(previous_orbit.buffer)
        self._orbit_bounds = orbit_bounds(values)
        self.stream = SampleStream(model, orbit, profile)
        self._imu_variances = (variance_from_rms_arcmin(values["imu.roll_error_rms_arcmin"]),
                               variance_from_rms_arcmin(values["imu.pitch_error_rms_arcmin"]))
        # Real time: the sample times, on the grid of the orbit's epoch (the node clock at the start).
        period_s = 1.0 / values["sensor.rate_hz"]
        self.grid = SampleGrid(self.clock_epoch_s, period_s) if self.grid is None else self.grid.with_period(period_s)
        timeout = values["attitude.follow_timeout_s"]
        # Older by more than the timeout: the source restarted on a new clock (once the next stamp confirms it).
        stamps = self._truth_stamps or StampCheck(timeout, timeout)
        self._truth_stamps = stamps.reconfigured(timeout, timeout, 1.0 / values["input.max_rate_hz"])
        previous = self.truth
        self.truth = TruthBuffer(values["attitude.extrapolation_periods"], values["attitude.follow_timeout_s"],
                                 bridge_s=values["attitude.extrapolation_s"])
        if previous is not None:  # a parameter change keeps the truth received so far
            self.truth.take_samples(previous)
        self.values = values

    # -- what the node shows ------------------------------------------------------------------

    @property
    def orbit(self):
        """The orbit the sensor flies."""
        return self.stream.orbit

    @property
    def fast_time_block(self) -> int:
        """Samples computed per call in fast time (:func:`pmv_ros.runtime.sensor.sample_stream.fast_time_block`)."""
        return fast_time_block(self.values["sensor.rate_hz"], self.values["sim.time_scale"], self.stepped)

    def now_s(self, clock_s: float) -> float:
        """Now on the sensor's own clock: simulation time in fast time, else ``clock_s`` (the node clock), s."""
        return self.sim_time_s if self.values["sim.fast_time"] else clock_s

    def _take(self) -> SensorOutput:
        out = self._out
        if not (out.published or out.log):  # nothing said: the same empty output again (no new object a message)
            return _NOTHING
        self._out = SensorOutput()
        return out

    # -- inputs ---------------------------------------------------------------------------------

    def add_truth(self, frame_id: str, stamp_s: float | None, q_xyzw, clock_s: float) -> SensorOutput:
        """Follow mode: one /attitude/truth message (``stamp_s`` None: unreadable); keep it or count why not.

        In real time the sample times that waited for this truth are sensed now.
        """
        rejection = check_frame(frame_id, self.frames.orbital)  # an inertial quaternion, say
        if rejection is not None:
            self.health.count(f"rejected_truth_{rejection.value}")
            return self._take()
        if stamp_s is None:  # negative or non-finite stamp
            self.health.count(f"rejected_truth_{Rejection.ZERO_STAMP.value}")
            return self._take()
        now_s = self.now_s(clock_s)
        sample = check_quaternion_sample(self._truth_stamps, stamp_s, q_xyzw, now_s)
        if sample.outliers:
            self.health.count("clock_outliers")
        if sample.jumped:
            self.health.count("clock_jumps")
            self.truth.clear()
        if sample.rejection is not None:
            self.health.count(f"rejected_truth_{sample.rejection.value}")
            return self._take()
        self.truth.add(stamp_s, sample.q_xyzw)
        if self._waiting and not self.values["sim.fast_time"]:  # sample times that waited for this truth
            self._sense_following(self._waiting.ready(self.truth, now_s))
        return self._take()

    def add_odometry(self, frame_id: str, child_frame_id: str, state, clock_s: float) -> None:
        """orbit.source follow: one orbit/odometry message, ``state`` (stamp s, position m, velocity m/s) in ECI
        or None when unreadable; keep a valid state, drop and count a bad one."""
        frames = self.frames
        rejection, jumped = check_odometry(frame_id, child_frame_id, state, frames.eci, frames.orbital,
                                           self._orbit_bounds, self._odometry_stamps, self.now_s(clock_s))
        if jumped:
            self.health.count("clock_jumps")
            self.stream.orbit.buffer.clear()
        if rejection is not None:
            self.health.count(f"rejected_odometry_{rejection.value}")
            return
        stamp_s, position, velocity = state
        buffer = self.stream.orbit.buffer
        buffer.add(stamp_s, position, velocity)
        # The sensor's field nodes placed ahead of the odometry are placed again once it covers them; a buffer
        # that started over (its first state) voids them all.
        self.stream.model.track.follow(stamp_s, reset=len(buffer) == 1)

    # -- ticks ----------------------------------------------------------------------------------

    def _advance(self) -> float:
        """Fast time: the simulation clock one sensor period on (one float addition per step), s."""
        self.sim_time_s += 1.0 / self.values["sensor.rate_hz"]
        return self.sim_time_s

    def step_block(self):
        """Fast time, stepped, the own profile on its own orbit: a whole block of steps at once — what
        :meth:`step` senses over the same steps, as arrays (a campaign's flight): (stamps ``(B,)`` s, attitude
        ``(4, B)``, the instrument's reading). Only at a block's start, and with nothing counted or published."""
        if self.following or self.orbit_following or not self.values["sim.fast_time"] or self.stream.pending:
            raise ValueError("step_block: fast time with the own attitude profile and orbit, at a block's start")
        block = self.fast_time_block
        first_s = self._advance()
        for _ in range(block - 1):
            self._advance()
        return self.stream.profile_block(first_s, 1.0 / self.values["sensor.rate_hz"], block)

    def step(self) -> SensorOutput:
        """Fast time: advance the simulation clock by one sensor period and sense that sample."""
        t_s = self._advance()
        if self.following:
            self._sense_following([(t_s, *self.truth.attitude_at(t_s))])
        elif self.orbit_following:
            self._sense_profile_on_followed_orbit([t_s])
        else:
            period = 1.0 / self.values["sensor.rate_hz"]
            for sample in self._orbit_samples(t_s, lambda: [self.stream.next_profile_sample(
                    t_s, period, self.fast_time_block)]):
                self._emit_sample(sample)
        return self._take()

    def step_to(self, times) -> SensorOutput:
        """A host that keeps its own clock (a spacecraft simulator's integer nanoseconds) steps the sensor: it
        measures at each of ``times`` (s, increasing, each after the last sample time) with the attitude and
        orbit followed so far, the samples as one block (as :meth:`tick` senses the due ones), and its clock
        then reads the last. The host passes its clock as ``clock_s`` with the inputs (``sim.fast_time``
        false) and chooses the sample times itself: no grid of the node clock's, no summing of periods
        (:meth:`step`'s clock drifts ≈ 3e-9 s from a host's after an orbit of 0.1 s steps). Follow mode only."""
        if not self.following:
            raise ValueError("step_to: a host steps the sensor with attitude.source follow")
        times = [float(t_s) for t_s in times]
        previous = self._host_time_s
        for t_s in times:
            if not (math.isfinite(t_s) and (previous is None or t_s > previous)):
                raise ValueError(f"step_to: sample time {t_s} s is not after the last one ({previous} s)")
            previous = t_s
        if times:
            self.sim_time_s = self._host_time_s = times[-1]
            self._sense_following([(t_s, *self.truth.attitude_at(t_s)) for t_s in times])
        return self._take()

    def tick(self, now_s: float) -> SensorOutput:
        """Real time: every sample of the grid due at node clock ``now_s`` since the last one, in order.

        A clock that steps by more than a period makes several due, so the
        samples are taken from the grid (:class:`~pmv_ros.runtime.sensor.sample_stream.SampleGrid`),
        not from the tick: with the own attitude profile computed in the
        grid's blocks (those of a fast-time run), in follow mode the due ones
        as one block. A confirmed clock jump restarts the grid at the new time.
        """
        jump = self._tick_clock.observe(now_s)
        if jump is Jump.OUTLIER:
            self.health.count("clock_outliers")
        if jump is Jump.SUSPECTED:
            self.health.count("skipped_unconfirmed_clock_jump")
            return self._take()
        if jump in (Jump.CONFIRMED_BACK, Jump.CONFIRMED_FORWARD):
            self.grid.restart()
            self._waiting.clear()
        indices = self.grid.due(now_s)
        if self.following:  # due times wait for the truth that covers them (it may come after the tick)
            self._waiting.add(self.grid.time_of(indices).tolist(), now_s)
            self._sense_following(self._waiting.ready(self.truth, now_s))
        elif not indices:
            pass
        elif self.orbit_following:
            self._sense_profile_on_followed_orbit(self.grid.time_of(indices).tolist())
        else:
            last_s = float(self.grid.time_of(indices[-1]))
            for sample in self._orbit_samples(last_s, lambda: self.stream.grid_profile_samples(self.grid, indices)):
                self._emit_sample(sample)
        return self._take()

    # -- sensing --------------------------------------------------------------------------------

    def _orbit_covered(self, times) -> list:
        """orbit.source follow: the times of ``times`` the followed orbit gives a state at. Each other one is
        counted (``skipped_<reason>``) and reports health only; a stale orbit is an ERROR, said once each
        way on the log, as for stale truth."""
        buffer, covered = self.stream.orbit.buffer, []
        for t_s in times:
            where = buffer.where(t_s)
            if where.usable:
                if self._orbit_problem is not None:
                    self._out.log.append(LogLine("info", f"{self.health.odometry_topic} covers the samples again "
                                                         f"at t = {t_s:.3f} s"))
                    self._orbit_problem = None
                covered.append(t_s)
                continue
            self.health.count(f"skipped_{where.value}")
            if self._orbit_problem is None or self._orbit_problem[0] is not where:
                newest = buffer.newest_stamp_s
                newest_text = "none" if newest is None else f"{newest:.3f} s"
                self._orbit_problem = (where, f"{self.health.odometry_topic}: {where.value.replace('_', ' ')} "
                                              f"at t = {t_s:.3f} s (newest state {newest_text}): "
                                              "no output until the odometry covers the sample times")
                if where is OrbitAt.STALE:
                    self._out.log.append(LogLine("error", self._orbit_problem[1]))
            self._emit_health(t_s)
        return covered

    def _sense_profile_on_followed_orbit(self, times) -> None:
        """orbit.source follow with the own attitude model: each covered time alone (no orbit exists ahead of
        the user's odometry to compute a block from)."""
        for t_s in self._orbit_covered(times):
            for sample in self._orbit_samples(t_s, lambda: self.stream.samples(
                    [t_s], self.stream.profile.quaternion(np.array([t_s])).T.tolist())):
                self._emit_sample(sample)

    def _sense_following(self, found: list) -> None:
        """Measure at each ``(t_s, q, source)`` of ``found`` (in order; the attitude the truth buffer gives at
        t_s and where it came from), the samples that have one computed as one block; a time without one
        reports nothing but health."""
        if not found:
            return
        usable = [item for item in found if item[2] in _USABLE_TRUTH]
        covered = set(self._orbit_covered([t for t, _, _ in usable])) if self.orbit_following else None
        if covered is not None:
            usable = [item for item in usable if item[0] in covered]
        samples = iter(self._orbit_samples(found[-1][0], lambda: self.stream.samples(
            [t for t, _, _ in usable], [q for _, q, _ in usable])) if usable else ())
        for t_s, _, source in found:
            self._truth_state = source
            usable_here = source in _USABLE_TRUTH
            # Said once each way: samples between the stale ones and the truth's return may read truth_gap.
            if source is _STALE and not self._stale_logged:
                self._stale_logged = True
                self._out.log.append(LogLine("error", f"{self.health.truth_topic} is stale at t = {t_s:.3f} s "
                                                      f"(newest {self.truth.newest_stamp_s:.3f} s): no angles until "
                                                      "it returns"))
            elif usable_here and self._stale_logged:
                self._stale_logged = False
                self._out.log.append(LogLine("info", f"{self.health.truth_topic} is back at t = {t_s:.3f} s"))
            if not usable_here:
                self.health.count(f"skipped_{source.value}")
                self._emit_health(t_s)
                continue
            if covered is not None and t_s not in covered:  # no orbit at t_s: counted and said already
                continue
            if source is _BRIDGED:  # a late truth sample, bridged by the last rate: counted, no alarm
                self.health.count("truth_bridged")
            sample = next(samples, None)
            if sample is not None:
                self._emit_sample(sample)

    def _orbit_samples(self, t_s: float, compute) -> list:
        """``compute()`` (a list of :class:`SensorSample`) unless the orbit has failed: [] then. An SGP4 error
        code stops the output for good: logged once as an ERROR, counted, and an ERROR on /diagnostics."""
        if self._orbit_error is None:
            try:
                return compute()
            except OrbitPropagationError as error:
                self._orbit_error = f"orbit: {error}: no output from here on"
                self._out.log.append(LogLine("error", self._orbit_error))
        self.health.count("skipped_orbit_error")
        self._emit_health(t_s)
        return []

    # -- output ---------------------------------------------------------------------------------

    def _emit_sample(self, sample: SensorSample) -> None:
        imu = estimator_orientation(sample.roll_rad, sample.pitch_rad, *self._imu_variances)
        self._out.published.append(SamplePublication(sample, imu))
        self.health.record_sample(sample.chord_status)
        self._emit_health(sample.t_s, sample.chord_status, sample.blinding_body)

    def _emit_health(self, t_s: float, status=None, blinding=None) -> None:
        """A /diagnostics report when due (every diagnostics_period_s, and at once on a change)."""
        period = self.values["diagnostics_period_s"]
        if self._graph_checked_s is None or not (0.0 <= t_s - self._graph_checked_s < period):
            self._graph_checked_s = t_s
            other_truth_publishers, self._source_errors = self._graph_problems()
            self._graph_warnings = truth_source_warnings(other_truth_publishers)
        source_errors = self._source_errors + ((self._orbit_error,) if self._orbit_error else ())
        warnings = self._graph_warnings
        if self._orbit_problem is not None:  # a stale followed orbit is an ERROR, one not there yet a WARN
            where, problem = self._orbit_problem
            source_errors, warnings = ((source_errors + (problem,), warnings) if where is OrbitAt.STALE
                                       else (source_errors, warnings + (problem,)))
        newest = self.truth.newest_stamp_s if self.following else None
        summary = self.health.report(
            t_s, period, status=status, blinding=blinding, truth=self._truth_state,
            exclusion_deg=self.values["sensor.bright_body_exclusion_deg"],
            truth_age_s=float("nan") if newest is None else t_s - newest,
            warnings=warnings + source_errors,
            no_sample=f"no {self.health.odometry_topic} state at the sample time" if self._orbit_problem else None)
        if summary is not None:
            level = max(summary.level, Level.ERROR if source_errors else Level.OK)  # a second source
            self._out.published.append(HealthAt(t_s, HealthSummary(
                Level(level), summary.message, {**summary.values, **self._source_counters()})))
