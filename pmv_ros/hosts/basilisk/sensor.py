"""The PMV as a Basilisk sensor module: Basilisk's spacecraft states in, the instrument's reading out.

:class:`PmvHorizonSensor` is a Python ``SysModel``. Each time its task runs
it reads the spacecraft's ``SCStatesMsg`` (``r_BN_N``, ``v_BN_N``,
``sigma_BN``, stamped with the time the message was written) and measures
at every time of the sensor's own sample grid (:class:`SampleClock`: sample
k at k / ``sensor.rate_hz`` s of Basilisk's clock) that the states it has
read cover, through the sensor node's own runtime
(:class:`~pmv_ros.runtime.sensor.runtime.SensorRuntime` in follow mode: the
same checks, sensing, stamping and oblateness compensation as the nodes; one
sample costs what one sample in a block costs, and reads the same).

Sample times and the task's period. A Python module cannot ask its task for
its period, so nothing can be checked at ``Reset``; instead the module
samples on the sensor's grid whatever the task: a sample time that is a
state's time is measured with that state; one between two states (3 Hz in a
0.1 s task) with the attitude and the orbit interpolated between them
(spherical-linear and cubic Hermite, :mod:`pmv_ros.runtime.common.truth_buffer`,
:mod:`pmv_ros.runtime.common.orbit_buffer`) — said once through ``bskLogger``;
in a task slower than the sensor (10 Hz in a 0.2 s task) every sample since
the last call is measured and reported at the call, late by up to a task
period — said once too. The runtime is fed only the states a sample needs
(the one at or before it and the one at or after it): a 1 kHz dynamics task
costs the module a message read a step.

Outputs:

* ``nadirOutMsg`` (``BodyHeadingMsg``, ``rHat_XB_B``): the local vertical the
  PMV measured, the unit vector towards the Earth's centre as the sensor
  sees it, in body components — what a Basilisk FSW module subscribes to
  (:class:`~pmv_ros.hosts.basilisk.nav.PmvAttitudeNav` makes a ``NavAttMsg``
  of it). Written once per sample whose two angles were measured, with the
  sample's own time (``timeWritten()``); a sample with a lost chord pair is
  not written, so the message's time says how old the reading is.
* :attr:`PmvHorizonSensor.reading` — the newest :class:`PmvReading`, the
  instrument's whole output in Basilisk's conventions (frames in the names,
  SI units): the corrected and uncorrected angles, validity, the four chords'
  status and lines of sight;
* :meth:`PmvHorizonSensor.recorder` — readings kept as arrays, at a decimation
  interval, within a bounded number;
* :meth:`PmvHorizonSensor.errorMonitor` — the residual statistics (physics.md §5).

Bad states are not the simulation's end: a state that is not finite, not a
bound Earth orbit (:func:`pmv_ros.runtime.common.validation.check_orbit_state`)
or without an orbital frame, and one stamped before the last one read or
after Basilisk's time, is dropped, counted (:attr:`PmvHorizonSensor.counters`, ``rejected_state_<reason>``)
and said once through ``bskLogger`` (``BSK_WARNING``). Any finite MRP is a
rotation (a set with |σ| > 1 is read as its shadow set). What the runtime
says goes to ``bskLogger`` too (``BSK_WARNING`` for its errors, which do not
stop the sensor). ``BSK_ERROR``, which ends a Basilisk simulation, is kept
for what must: a ``scStateInMsg`` not linked, an ``epochInMsg`` that is
linked but carries no valid epoch, at ``Reset``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from Basilisk.architecture import bskLogging, messaging, sysModel

from ...physics.attitude import true_roll_pitch
from ...runtime.common.assembly import orbit_bounds, read_correction
from ...runtime.common.validation import Rejection, check_orbit_state
from ...runtime.sensor.runtime import SensorRuntime
from .frames import case_attitude, check_dcm, dcm_tuple, nadir_in_body
from .monitor import PmvErrorMonitor
from .values import HOST_CLOCK_OFFSET_S, SampleClock, epoch_utc, host_values, read_preset


class PmvReading(NamedTuple):
    """One PMV sample in Basilisk's conventions (frames in names; SI units)."""

    timeTag: float  #: [s] Basilisk time of the sample
    roll_CO: float  #: [rad] roll of the case frame C in the orbital frame O (REP-103) as output; NaN: ±Y lost
    pitch_CO: float  #: [rad] pitch of C in O (REP-103) as output (corrections applied); NaN: ±X lost
    rollUncorrected_CO: float  #: [rad] roll before the brightness correction
    pitchUncorrected_CO: float  #: [rad] pitch before the brightness correction
    valid: bool  #: [-] both angles measured
    #: [-] 4 codes, chords +X, +Y, −X, −Y (:class:`~pmv_ros.physics.instrument.sensor.ChordStatus`, 0 valid)
    chordStatus: tuple
    lineOfSight_C: tuple  #: [-] 4 × (x, y, z) unit lines of sight to the horizon crossings in C (NaN: lost)


#: One recorded reading: its layout in :class:`PmvRecorder` (157 bytes).
RECORD = np.dtype([("time", np.int64), ("roll_CO", float), ("pitch_CO", float), ("rollUncorrected_CO", float),
                   ("pitchUncorrected_CO", float), ("trueRoll_CO", float), ("truePitch_CO", float),
                   ("valid", bool), ("chordStatus", np.int8, (4,)), ("lineOfSight_C", float, (4, 3))])

#: Readings a recorder makes room for at first (it doubles its room as it fills, up to its capacity).
_FIRST_ROOM = 1024


class PmvRecorder:
    """Readings of a :class:`PmvHorizonSensor` since the simulation was initialised, as arrays (a Basilisk
    message recorder's habit: ``times()`` in ns, one attribute a field), with the true roll and pitch each
    sample was measured at (``trueRoll_CO``, ``truePitch_CO``, rad) for comparison.

    Args:
        interval_s: the least time between two recorded readings, s (Basilisk's recorder's ``timeDiff``): a
            reading is kept when it is at least this much after the last one kept; 0 keeps every one.
        capacity: the most readings kept (None: no bound); beyond it the oldest are dropped (:attr:`dropped`).

    Memory: :data:`RECORD` (157 bytes) a reading kept — 13.6 MB a simulated day at ``interval_s`` 1 s.
    """

    def __init__(self, interval_s: float = 0.0, capacity: int | None = None):
        if not (isinstance(interval_s, (int, float)) and not isinstance(interval_s, bool)
                and math.isfinite(interval_s) and 0.0 <= interval_s <= 86400.0):
            raise ValueError(f"interval_s = {interval_s!r} must be a number of seconds in 0 … 86400")
        if capacity is not None and not (isinstance(capacity, int) and not isinstance(capacity, bool)
                                         and 1 <= capacity <= 10**9):
            raise ValueError(f"capacity = {capacity!r} must be None or a whole number in 1 … 1e9")
        self.interval_ns = round(interval_s * 1e9)
        self.capacity = capacity
        self.clear()

    def clear(self) -> None:
        """Forget what was recorded."""
        self._rows = np.empty(0, RECORD)
        self._count = 0  # readings kept so far, dropped ones included
        self._next_ns = None  # no reading before this time is kept
        self.dropped = 0  #: readings dropped for the capacity

    def add(self, time_ns: int, sample) -> None:
        """Keep the runtime's ``sample`` (:class:`~pmv_ros.runtime.sensor.sample_stream.SensorSample`), read at
        Basilisk time ``time_ns``, unless it is within the interval of the last one kept."""
        if self._next_ns is not None and time_ns < self._next_ns:
            return
        self._next_ns = time_ns + self.interval_ns
        rows = self._rows
        if self._count >= rows.size and (self.capacity is None or rows.size < self.capacity):
            room = max(_FIRST_ROOM, 2 * rows.size)
            rows = self._rows = np.concatenate([rows, np.empty(room if self.capacity is None else
                                                               min(room, self.capacity) - rows.size, RECORD)])
        if self._count >= rows.size:
            self.dropped += 1
        true_roll, true_pitch = true_roll_pitch(np.array(sample.q_xyzw))
        roll, pitch = sample.roll_rad, sample.pitch_rad
        rows[self._count % rows.size] = (time_ns, roll, pitch, sample.roll_uncorrected_rad,
                                         sample.pitch_uncorrected_rad, true_roll, true_pitch,
                                         roll == roll and pitch == pitch, sample.chord_status, sample.line_of_sight)
        self._count += 1

    def _kept(self) -> np.ndarray:
        """The readings kept, oldest first."""
        kept = min(self._count, self._rows.size)
        if self._count <= self._rows.size:
            return self._rows[:kept]
        start = self._count % self._rows.size
        return np.concatenate([self._rows[start:], self._rows[:start]])

    def __len__(self) -> int:
        return min(self._count, self._rows.size)

    @property
    def nbytes(self) -> int:
        """Memory of the readings' room, bytes."""
        return self._rows.nbytes

    def times(self) -> np.ndarray:
        """Basilisk times of the readings, ns, ``(N,)``."""
        return self._kept()["time"].copy()

    def __getattr__(self, name):
        if name in RECORD.names and name != "time":
            return self._kept()[name].copy()
        raise AttributeError(name)


def log_line(module, own_logger, level: int, text: str):
    """``text`` through ``module``'s ``bskLogger`` (``own_logger``, made when None, while the module is in no task):
    prefixed with its ModelTag, cut to Basilisk's longest line. Returns the logger it made or was given."""
    line = f"{module.ModelTag}: {text}"
    if len(line) >= bskLogging.MAX_LOGGING_LENGTH:
        line = line[:bskLogging.MAX_LOGGING_LENGTH - 4] + "..."
    logger = module.bskLogger
    if logger is None:
        logger = own_logger = own_logger or bskLogging.BSKLogger()
    logger.bskLog(level, line)
    return own_logger


def _short(vector) -> str:
    """A vector in a log line: four significant digits."""
    return "[" + ", ".join(f"{x:.4g}" for x in vector) + "]"


class PmvHorizonSensor(sysModel.SysModel):
    """The PMV infrared horizon sensor in a Basilisk simulation.

    Args:
        preset: a params file (``config/kondor.yaml``) or its parsed document: the sensor_node section (and
            the star tracker's and the monitor's, for :meth:`errorMonitor`).
        overrides: parameter values that win over the preset (dotted names, as ``-p``).
        dcm_CB: the PMV's case frame C in the body frame B, ``[CB]`` (B components → C components);
            :data:`~pmv_ros.hosts.basilisk.frames.DCM_CB_HILL` for a body Basilisk's ``hillPoint`` points.

    Messages: ``scStateInMsg`` (``SCStatesMsg``, required), ``epochInMsg`` (``EpochMsg``, optional: the
    simulation's epoch at Basilisk's time 0, instead of the preset's ``sim.epoch_utc``); ``nadirOutMsg``
    (``BodyHeadingMsg``, the measured nadir in body components).

    Raises ValueError (one line) for a bad preset, value or combination — as the node and the CLI refuse them.
    """

    def __init__(self, preset, overrides: dict | None = None, *, dcm_CB=np.eye(3)):
        super().__init__()
        self.ModelTag = "pmvHorizonSensor"
        self.scStateInMsg = messaging.SCStatesMsgReader()
        self.epochInMsg = messaging.EpochMsgReader()
        self.nadirOutMsg = messaging.BodyHeadingMsg()
        self._nadir = messaging.BodyHeadingMsgPayload()  # filled and written at each sample
        self.dcm_CB = check_dcm(dcm_CB)
        self._cb = dcm_tuple(self.dcm_CB)
        self._document = read_preset(preset)
        self.values = host_values(self._document, overrides)
        self._overrides = dict(overrides or {})
        self.runtime = None
        self._recorders: list[PmvRecorder] = []
        self._monitors: list[PmvErrorMonitor] = []
        self._own_logger = None
        self._start()  # the runtime built now, so that a bad combination is refused now

    # -- what a user attaches ---------------------------------------------------------------------

    def recorder(self, interval_s: float = 0.0, capacity: int | None = None) -> PmvRecorder:
        """A recorder of the readings from the next initialisation on: one every ``interval_s`` at most, the
        newest ``capacity`` kept (:class:`PmvRecorder`)."""
        recorder = PmvRecorder(interval_s, capacity)
        self._recorders.append(recorder)
        return recorder

    def errorMonitor(self) -> PmvErrorMonitor:
        """The error monitor (physics.md §5) on this sensor's readings and Basilisk's truth, through the node's
        star tracker and monitor runtimes: its statistics after a run (:meth:`PmvErrorMonitor.summary`)."""
        monitor = PmvErrorMonitor(self.values, HOST_CLOCK_OFFSET_S)
        self._monitors.append(monitor)
        return monitor

    @property
    def counters(self) -> dict:
        """What the module counted: the runtime's counters (inputs rejected per reason, skipped samples, ...)
        and the module's own (``rejected_state_<reason>``: states dropped before they reach the runtime)."""
        return {**self.runtime.health.counters, **self._counters}

    # -- Basilisk's calls ---------------------------------------------------------------------------

    def _start(self) -> None:
        """A new run on :attr:`values`: a new runtime, sample grid and counters; recorders and monitors emptied."""
        sensor = self.values.sensor
        self.runtime = SensorRuntime(sensor, clock_epoch_s=HOST_CLOCK_OFFSET_S, correction=read_correction(sensor))
        self._frames = (self.runtime.frames.orbital, self.runtime.frames.eci)
        self._bounds = orbit_bounds(sensor)
        self._clock = SampleClock(sensor["sensor.rate_hz"])
        self._next_index = None  # the next sample of the grid (set by the first state)
        self._newest_ns = -1  # the newest state read
        self._held = None  # the newest state read and not fed: (time ns, r, v, q)
        self._fed_ns = -1  # the newest state fed to the runtime
        self._counters: dict[str, int] = {}
        self._said: set[str] = set()
        self.reading: PmvReading | None = None  #: the newest reading
        self.health = None  #: the newest /diagnostics-style status (a HealthSummary)
        for recorder in self._recorders:
            recorder.clear()
        for monitor in self._monitors:
            monitor.reset(self.values)

    def _log(self, level: int, text: str) -> None:
        """A line through the simulation's ``bskLogger`` (the module's own when it is in no task yet)."""
        self._own_logger = log_line(self, self._own_logger, level, text)

    def _say_once(self, key: str, level: int, text: str) -> None:
        if key not in self._said:
            self._said.add(key)
            self._log(level, text)

    def _count(self, reason: str) -> None:
        self._counters[reason] = self._counters.get(reason, 0) + 1

    def Reset(self, CurrentSimNanos):
        """A new run: the epoch from ``epochInMsg`` when linked, a new runtime, the recorders and monitors
        emptied. ``BSK_ERROR`` (which ends the simulation) for an unlinked ``scStateInMsg`` or a bad epoch."""
        if not self.scStateInMsg.isLinked():
            self._log(bskLogging.BSK_ERROR, "scStateInMsg is not linked (subscribe it to the spacecraft's "
                                            "scStateOutMsg)")
        if not self.epochInMsg.isLinked():
            self._start()
            return
        if not self.epochInMsg.isWritten():
            self._log(bskLogging.BSK_ERROR, "epochInMsg is linked but was never written: no epoch to start from")
        epoch = self.epochInMsg()
        try:
            self.values = host_values(self._document, dict(self._overrides, **{"sim.epoch_utc": epoch_utc(
                epoch.year, epoch.month, epoch.day, epoch.hours, epoch.minutes, epoch.seconds)}))
            self._start()
        except ValueError as error:  # a date that is none (the runtime parses it)
            self._log(bskLogging.BSK_ERROR, f"epochInMsg: {error}")

    def UpdateState(self, CurrentSimNanos):
        """Read the newest state, and measure at the sample times the states read so far cover."""
        reader = self.scStateInMsg
        if not reader.isWritten():
            return
        time_ns = reader.timeWritten()
        if time_ns > CurrentSimNanos:  # no writer in the simulation writes ahead of its clock
            self._count("rejected_state_future_stamp")
            self._say_once("future", bskLogging.BSK_WARNING,
                           f"scStateInMsg written at {time_ns * 1e-9:.9f} s, after Basilisk's time "
                           f"({CurrentSimNanos * 1e-9:.9f} s): dropped (rejected_state_future_stamp counts them)")
            return
        if time_ns <= self._newest_ns:
            if time_ns < self._newest_ns:  # the same state again is no news; an older one is
                self._count("rejected_state_backwards")
                self._say_once("backwards", bskLogging.BSK_WARNING,
                               f"scStateInMsg written at {time_ns * 1e-9:.9f} s, before the state read last "
                               f"({self._newest_ns * 1e-9:.9f} s): dropped (rejected_state_backwards counts them)")
            return
        state = reader()
        r, v, sigma = tuple(state.r_BN_N), tuple(state.v_BN_N), tuple(state.sigma_BN)
        rejection = check_orbit_state(r, v, self._bounds)
        q = case_attitude(r, v, sigma, self._cb) if rejection is None else None
        if rejection is None and not q[3] == q[3]:  # NaN: a non-finite MRP, or no orbital frame
            rejection = Rejection.NON_FINITE if not all(map(math.isfinite, sigma)) else Rejection.IMPLAUSIBLE_ORBIT
        if rejection is not None:
            self._count(f"rejected_state_{rejection.value}")
            self._say_once(rejection.value, bskLogging.BSK_WARNING,
                           f"scStateInMsg at {time_ns * 1e-9:.3f} s dropped, {rejection.value.replace('_', ' ')} "
                           f"(rejected_state_{rejection.value} counts them): r_BN_N {_short(r)}, v_BN_N {_short(v)}, "
                           f"sigma_BN {_short(sigma)}")
            return
        self._newest_ns = time_ns
        if self._next_index is None:
            self._next_index = self._clock.first_index_at_or_after(time_ns)
        due_ns = self._clock.time_ns(self._next_index)
        if time_ns < due_ns:  # no sample yet: kept, in case the next state passes a sample time
            self._held = (time_ns, r, v, q)
            return
        held, self._held = self._held, None
        if held is not None and due_ns < time_ns:  # a sample before this state: interpolated from the one before
            self._feed(*held)
        previous_ns = self._fed_ns
        self._feed(time_ns, r, v, q)
        self._sense(time_ns, previous_ns, CurrentSimNanos)

    def _feed(self, time_ns: int, r, v, q) -> None:
        """The state at Basilisk time ``time_ns`` to the runtime: its orbit and its case attitude ``q``."""
        t_s = time_ns * 1e-9 + HOST_CLOCK_OFFSET_S
        runtime = self.runtime
        orbital, eci = self._frames
        runtime.add_odometry(eci, orbital, (t_s, r, v), t_s)
        runtime.add_truth(orbital, t_s, q, t_s)
        self._fed_ns = time_ns

    def _sense(self, newest_ns: int, previous_ns: int, now_ns: int) -> None:
        """Measure at every sample time up to ``newest_ns``, the state just fed (``previous_ns``: the one fed
        before it, −1 for none; ``now_ns``: Basilisk's time of the call)."""
        clock, index, times_ns = self._clock, self._next_index, []
        while (time_ns := clock.time_ns(index)) <= newest_ns:
            times_ns.append(time_ns)
            index += 1
        self._next_index = index
        if times_ns[0] != newest_ns:
            self._say_once("between", bskLogging.BSK_INFORMATION,
                           f"sample at {times_ns[0] * 1e-9:.6f} s lies between states at "
                           f"{max(previous_ns, 0) * 1e-9:.6f} and {newest_ns * 1e-9:.6f} s: interpolated from both, "
                           f"reported {(now_ns - times_ns[0]) * 1e-9:.3f} s late (off the states' times: a rate off "
                           "their grid, a slower task or a dropped state)")
        output = self.runtime.step_to([time_ns * 1e-9 + HOST_CLOCK_OFFSET_S for time_ns in times_ns])
        for line in output.log:
            self._log(bskLogging.BSK_WARNING if line.level == "error" else bskLogging.BSK_INFORMATION, line.text)
        if not output.published:
            return
        health = output.health
        if health:
            self.health = health[-1].health
        samples = output.samples
        by_time = {time_ns * 1e-9 + HOST_CLOCK_OFFSET_S: time_ns for time_ns in times_ns}
        cb, payload = self._cb, self._nadir
        for sample in samples:
            time_ns = by_time[sample.t_s]
            roll, pitch = sample.roll_rad, sample.pitch_rad
            valid = roll == roll and pitch == pitch
            self.reading = PmvReading(time_ns * 1e-9, roll, pitch, sample.roll_uncorrected_rad,
                                      sample.pitch_uncorrected_rad, valid, sample.chord_status, sample.line_of_sight)
            if valid:
                payload.rHat_XB_B = nadir_in_body(roll, pitch, cb)
                self.nadirOutMsg.write(payload, time_ns, self.moduleID)
            for recorder in self._recorders:
                recorder.add(time_ns, sample)
        for monitor in self._monitors:
            monitor.add_samples(samples)
