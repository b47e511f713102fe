"""The PMV as a Basilisk sensor module: Basilisk's spacecraft states in, the instrument's reading out.

:class:`PmvHorizonSensor` is a Python ``SysModel``. Each time its task runs
it reads the spacecraft's ``SCStatesMsg`` (``r_BN_N``, ``v_BN_N``,
``sigma_BN``, stamped with the time the message was written), feeds the
attitude of the PMV's case frame in the local orbital frame and the orbit
state to the sensor node's own runtime
(:class:`~pmv_ros.runtime.sensor.runtime.SensorRuntime`, follow mode: the
same checks, sensing, stamping and oblateness compensation as the nodes),
and measures at every sample time of ``sensor.rate_hz`` that Basilisk's
clock reached (:meth:`~pmv_ros.runtime.sensor.runtime.SensorRuntime.step_to`).

Output — a Python-side record, :class:`PmvReading`, on ``reading`` and in
:meth:`PmvHorizonSensor.recorder`: no Basilisk payload carries what the
instrument says. ``NavAttMsg`` and ``AttGuidMsg`` hold a three-axis
attitude, rates and (for the latter) a reference, none of which a horizon
sensor measures — filling them would invent yaw and rates; none has room
for the uncorrected angles, the validity or the four crossings. The record
follows Basilisk's conventions: frames in the names (``roll_CO``: the case
frame C relative to the orbital frame O), units in the comments, SI units,
``timeTag`` in seconds. :class:`~pmv_ros.hosts.basilisk.nav.PmvAttitudeNav`
turns it into a ``NavAttMsg`` for Basilisk's FSW, with yaw and rate from
elsewhere.

Batches: Basilisk calls a module once per task period with the newest
message only, so a module at the sensor's rate senses one sample a call
(≈ 5 ms with the environment of the Kondor preset: the fields are evaluated
per call). A module in a slower task can be given every state of the
dynamics task through a recorder (:meth:`PmvHorizonSensor.batchStates`);
it then senses them as blocks (≈ 50 µs a sample) — for open-loop studies,
as the readings come up to one module period late. The environment's fields
are interpolated over a block, so a reading depends on how samples are
grouped by ≈ 2e-4′ (README "Fast time").
"""

from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
from Basilisk.architecture import messaging, sysModel

from ...physics.attitude import true_roll_pitch
from ...runtime.common.assembly import read_correction
from ...runtime.sensor.runtime import SensorRuntime
from .frames import attitude_in_orbital, check_dcm
from .monitor import PmvErrorMonitor
from .values import HOST_CLOCK_OFFSET_S, epoch_utc, host_values, read_preset

LOG = logging.getLogger("pmv_ros.basilisk")

#: States fed to the runtime before it senses them: its truth and orbit buffers keep 256.
BATCH_STATES = 250


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


def _reading(time_tag_s: float, sample) -> PmvReading:
    roll, pitch = sample.roll_rad, sample.pitch_rad
    return PmvReading(time_tag_s, roll, pitch, sample.roll_uncorrected_rad, sample.pitch_uncorrected_rad,
                      roll == roll and pitch == pitch, sample.chord_status, sample.line_of_sight)


class PmvRecorder:
    """Every reading of a :class:`PmvHorizonSensor` since the simulation was initialised, as arrays (a Basilisk
    message recorder's habit: ``times()`` in ns, one attribute a field), with the true roll and pitch each sample
    was measured at (``trueRoll_CO``, ``truePitch_CO``, rad) for comparison."""

    _FIELDS = ("roll_CO", "pitch_CO", "rollUncorrected_CO", "pitchUncorrected_CO", "trueRoll_CO", "truePitch_CO")

    def __init__(self):
        self.clear()

    def clear(self) -> None:
        """Forget what was recorded."""
        self._times, self._valid, self._status, self._los = [], [], [], []
        self._columns = {name: [] for name in self._FIELDS}

    def add(self, time_ns: int, reading: PmvReading, q_xyzw) -> None:
        """Record one reading and the true attitude it was measured at."""
        self._times.append(time_ns)
        columns = self._columns
        for name, value in zip(self._FIELDS[:4], reading[1:5]):
            columns[name].append(value)
        true_roll, true_pitch = true_roll_pitch(np.asarray(q_xyzw, float))
        columns["trueRoll_CO"].append(true_roll)
        columns["truePitch_CO"].append(true_pitch)
        self._valid.append(reading.valid)
        self._status.append(reading.chordStatus)
        self._los.append(reading.lineOfSight_C)

    def times(self) -> np.ndarray:
        """Basilisk times of the readings, ns."""
        return np.array(self._times, np.int64)

    def __len__(self) -> int:
        return len(self._times)

    def __getattr__(self, name):
        if name in self._FIELDS:
            return np.array(self._columns[name], float)
        raise AttributeError(name)

    @property
    def valid(self) -> np.ndarray:
        """Whether both angles were measured, ``(N,)`` bool."""
        return np.array(self._valid, bool)

    @property
    def chordStatus(self) -> np.ndarray:
        """Chord status codes, ``(N, 4)``."""
        return np.array(self._status, np.int8).reshape(-1, 4)

    @property
    def lineOfSight_C(self) -> np.ndarray:
        """Unit lines of sight to the four crossings in the case frame, ``(N, 4, 3)``."""
        return np.array(self._los, float).reshape(-1, 4, 3)


class PmvHorizonSensor(sysModel.SysModel):
    """The PMV infrared horizon sensor in a Basilisk simulation.

    Args:
        preset: a params file (``config/kondor.yaml``) or its parsed document: the sensor_node section (and
            the star tracker's and the monitor's, for :meth:`errorMonitor`).
        overrides: parameter values that win over the preset (dotted names, as ``-p``).
        dcm_CB: the PMV's case frame C in the body frame B, ``[CB]`` (B components → C components);
            :data:`~pmv_ros.hosts.basilisk.frames.DCM_CB_HILL` for a body Basilisk's ``hillPoint`` points.

    Messages: ``scStateInMsg`` (``SCStatesMsg``, required), ``epochInMsg`` (``EpochMsg``, optional: the
    simulation's epoch at Basilisk's time 0, instead of the preset's ``sim.epoch_utc``).

    Raises ValueError (one line) for a bad preset, value or combination — as the node and the CLI refuse them.
    """

    def __init__(self, preset, overrides: dict | None = None, *, dcm_CB=np.eye(3)):
        super().__init__()
        self.ModelTag = "pmvHorizonSensor"
        self.scStateInMsg = messaging.SCStatesMsgReader()
        self.epochInMsg = messaging.EpochMsgReader()
        self.dcm_CB = check_dcm(dcm_CB)
        self._document, self._overrides = read_preset(preset), dict(overrides or {})
        self.values = host_values(self._document, self._overrides)
        self._correction = read_correction(self.values.sensor)
        self.runtime = self._new_runtime()  # built now, so that a bad combination is refused now
        self.reading: PmvReading | None = None  #: the newest reading
        self.health = None  #: the newest /diagnostics-style status (a HealthSummary)
        self._recorders: list[PmvRecorder] = []
        self._monitors: list[PmvErrorMonitor] = []
        self._states = None  # the recorder of the dynamics task's states (batchStates)
        self._period_ns = round(1e9 / self.values.sensor["sensor.rate_hz"])  # the sample grid on Basilisk's clock
        self._last_state_ns = -1

    # -- what a user attaches ---------------------------------------------------------------------

    def recorder(self) -> PmvRecorder:
        """A recorder of every reading from the next initialisation on."""
        recorder = PmvRecorder()
        self._recorders.append(recorder)
        return recorder

    def errorMonitor(self) -> PmvErrorMonitor:
        """The error monitor (physics.md §5) on this sensor's readings and Basilisk's truth, through the node's
        star tracker and monitor runtimes: its statistics after a run (:meth:`PmvErrorMonitor.summary`)."""
        monitor = PmvErrorMonitor(self.values, HOST_CLOCK_OFFSET_S)
        self._monitors.append(monitor)
        return monitor

    def batchStates(self):
        """A recorder of ``scStateInMsg``'s source to add to the dynamics task (subscribe first): the module
        then senses every state recorded since its last call, as blocks, instead of the newest message only."""
        if not self.scStateInMsg.isLinked():
            raise ValueError("batchStates: subscribe scStateInMsg to the spacecraft's scStateOutMsg first")
        self._states = self.scStateInMsg.recorder()
        return self._states

    @property
    def counters(self) -> dict:
        """The runtime's counters (samples published, inputs rejected per reason, skipped samples, ...)."""
        return dict(self.runtime.health.counters)

    # -- Basilisk's calls ---------------------------------------------------------------------------

    def _new_runtime(self) -> SensorRuntime:
        return SensorRuntime(self.values.sensor, clock_epoch_s=HOST_CLOCK_OFFSET_S, correction=self._correction)

    def Reset(self, CurrentSimNanos):
        """A new run: the epoch from ``epochInMsg`` when linked, a new runtime, the recorders and monitors
        emptied."""
        if self.epochInMsg.isLinked():
            epoch = self.epochInMsg()
            overrides = dict(self._overrides, **{"sim.epoch_utc": epoch_utc(
                epoch.year, epoch.month, epoch.day, epoch.hours, epoch.minutes, epoch.seconds)})
            self.values = host_values(self._document, overrides)
        self.runtime = self._new_runtime()
        self._period_ns = round(1e9 / self.values.sensor["sensor.rate_hz"])
        self._last_state_ns = -1
        self.reading = self.health = None
        for recorder in self._recorders:
            recorder.clear()
        for monitor in self._monitors:
            monitor.reset(self.values)

    def UpdateState(self, CurrentSimNanos):
        """Feed the new state(s) and measure at the sample times among them."""
        if self._states is not None:
            states = self._states
            if not states.size():
                return
            times = states.timesWritten()
            fresh = times > self._last_state_ns
            r, v, sigma = states.r_BN_N[fresh], states.v_BN_N[fresh], states.sigma_BN[fresh]
            times = times[fresh]
            states.clear()
            for start in range(0, times.size, BATCH_STATES):
                chunk = slice(start, start + BATCH_STATES)
                self._sense(times[chunk], r[chunk], v[chunk], sigma[chunk])
            return
        if not self.scStateInMsg.isWritten():
            return
        written = self.scStateInMsg.timeWritten()
        if written <= self._last_state_ns:
            return
        state = self.scStateInMsg()
        self._sense(np.array([written]), np.array([state.r_BN_N]), np.array([state.v_BN_N]),
                    np.array([state.sigma_BN]))

    def _sense(self, times_ns: np.ndarray, r, v, sigma) -> None:
        """Feed states at Basilisk times ``times_ns`` (increasing) and measure at those on the sample grid."""
        runtime, frames = self.runtime, self.runtime.frames
        q = attitude_in_orbital(r, v, sigma, self.dcm_CB).T.tolist()
        clock = (times_ns * 1e-9 + HOST_CLOCK_OFFSET_S).tolist()
        r, v = r.tolist(), v.tolist()
        for k, t_s in enumerate(clock):
            runtime.add_truth(frames.orbital, t_s, q[k], t_s)
            runtime.add_odometry(frames.eci, frames.orbital, (t_s, r[k], v[k]), t_s)
        self._last_state_ns = int(times_ns[-1])
        on_grid = np.flatnonzero(times_ns % self._period_ns == 0)
        if not on_grid.size:
            return
        nanos = {clock[k]: int(times_ns[k]) for k in on_grid.tolist()}
        output = runtime.step_to([clock[k] for k in on_grid.tolist()])
        for line in output.log:
            (LOG.error if line.level == "error" else LOG.info)("%s: %s", self.ModelTag, line.text)
        if output.health:
            self.health = output.health[-1].health
        samples = output.samples
        for sample in samples:
            time_ns = nanos[sample.t_s]
            reading = self.reading = _reading(time_ns * 1e-9, sample)
            for recorder in self._recorders:
                recorder.add(time_ns, reading, sample.q_xyzw)
        for monitor in self._monitors:
            monitor.add_samples(samples)
