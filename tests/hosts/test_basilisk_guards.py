"""The PMV module's guards, tried in Basilisk as a careless user and a hostile writer of its inputs would.

Hostile ``SCStatesMsg`` states (issue 50 item 8), stamps going backwards, sensor rates off the task's period
(issue 48 item 3), inputs not linked, and the navigation bridge without a sensor or with another navigation's
yaw. Each test says what was sent; Basilisk's ``bskLogger`` prints to the process's stdout (captured here with
``capfd``), so each checks what the module said and how often.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("Basilisk", reason="bsk (Basilisk) is not installed: pip install pmv_ros[basilisk]")

from Basilisk.architecture import messaging, sysModel  # noqa: E402
from Basilisk.simulation import simpleNav, spacecraft  # noqa: E402
from Basilisk.utilities import SimulationBaseClass, macros  # noqa: E402

from flights import REPO  # noqa: E402
from pmv_ros.hosts.basilisk import (DCM_CB_HILL, PmvAttitudeNav, PmvHorizonSensor, attitude_in_orbital,  # noqa: E402
                                    sigma_from_roll_pitch_yaw)
from pmv_ros.hosts.basilisk.replay import replay_states  # noqa: E402
from pmv_ros.hosts.basilisk.scenario import INERTIA_KG_M2, MASS_KG, earth_gravity, preset_orbit  # noqa: E402
from pmv_ros.physics.attitude import roll_pitch_yaw_from_quaternion  # noqa: E402
from pmv_ros.physics.constants import ARCMIN_RAD  # noqa: E402

KONDOR = str(REPO / "config" / "kondor.yaml")
GEOMETRIC = {"sensor.detector": "ideal", "radiance.source": "uniform", "sensor.bright_body_exclusion_deg": 0.0}
#: The module against the runtime fed the same states (issue 48: the physics held to 0.002′).
SAME_STATES_ARCMIN = 0.002


class StateWriter(sysModel.SysModel):
    """Writes the spacecraft's state again as its own ``scStateOutMsg``, changed at chosen steps: ``edits`` maps a
    step number to ``edit(payload, time_ns) -> time_ns`` (which may change the payload and the stamp)."""

    def __init__(self, edits=None):
        super().__init__()
        self.scStateInMsg = messaging.SCStatesMsgReader()
        self.scStateOutMsg = messaging.SCStatesMsg()
        self.edits, self.step = dict(edits or {}), 0

    def UpdateState(self, CurrentSimNanos):
        payload = self.scStateInMsg()
        time_ns = CurrentSimNanos
        edit = self.edits.get(self.step)
        if edit is not None:
            time_ns = edit(payload, time_ns)
        self.scStateOutMsg.write(payload, time_ns, self.moduleID)
        self.step += 1


class Flight:
    """A spacecraft on the Kondor preset's orbit turning with its Hill frame (``roll_rad`` off it, and turning
    about its B1 axis at ``roll_rate_rad_s`` too), no control; modules added by :meth:`add`; states recorded at
    every step of the dynamics task."""

    def __init__(self, dynamics_step_s: float = 0.1, roll_rad: float = 0.0, roll_rate_rad_s: float = 0.0):
        self.sim = SimulationBaseClass.SimBaseClass()
        self.process = self.sim.CreateNewProcess("process")
        self.process.addTask(self.sim.CreateNewTask("dynamics", macros.sec2nano(dynamics_step_s)), 100)
        orbit = preset_orbit(PmvHorizonSensor(KONDOR).values)
        r0, v0 = orbit.state_eci(0.0)
        self.body = body = spacecraft.Spacecraft()
        body.hub.mHub = MASS_KG
        body.hub.IHubPntBc_B = [list(row) for row in INERTIA_KG_M2]
        body.hub.r_CN_NInit, body.hub.v_CN_NInit = r0.tolist(), v0.tolist()
        body.hub.sigma_BNInit = sigma_from_roll_pitch_yaw(roll_rad, 0.0, 0.0, r0, v0, DCM_CB_HILL)[0].tolist()
        body.hub.omega_BN_BInit = [roll_rate_rad_s, 0.0, orbit.mean_motion_rad_s]
        self.earth = earth_gravity(False)
        body.gravField.gravBodies = spacecraft.GravBodyVector([self.earth])
        self.sim.AddModelToTask("dynamics", body, 100)
        self.states = body.scStateOutMsg.recorder()
        self.sim.AddModelToTask("dynamics", self.states, 99)
        self.modules = []

    def task(self, name: str, step_s: float) -> str:
        """Another task of ``step_s``, run after the dynamics task in a step they share."""
        self.process.addTask(self.sim.CreateNewTask(name, macros.sec2nano(step_s)), 50)
        return name

    def add(self, module, priority: int, task: str = "dynamics"):
        self.sim.AddModelToTask(task, module, priority)
        self.modules.append(module)
        return module

    def run(self, duration_s: float) -> None:
        self.sim.InitializeSimulation()
        self.sim.ConfigureStopTime(macros.sec2nano(duration_s))
        self.sim.ExecuteSimulation()


def pmv_on(source, overrides=None) -> PmvHorizonSensor:
    pmv = PmvHorizonSensor(KONDOR, {**GEOMETRIC, **(overrides or {})}, dcm_CB=DCM_CB_HILL)
    pmv.scStateInMsg.subscribeTo(source)
    return pmv


def said(capfd, text: str) -> int:
    """How many lines of the captured output contain ``text``."""
    out, err = capfd.readouterr()
    said.last = out + err
    return sum(text in line for line in (out + err).splitlines())


def largest_difference_arcmin(readings, samples) -> float:
    module = np.stack([readings.roll_CO, readings.pitch_CO])
    replayed = np.array([[s.roll_rad, s.pitch_rad] for s in samples]).T
    assert np.array_equal(np.isnan(module), np.isnan(replayed))
    return float(np.nanmax(abs(module - replayed))) / ARCMIN_RAD


def test_basilisk_guards_hostile_states_are_dropped_counted_and_said_once(capfd):
    # A writer between the spacecraft and the PMV sends, at steps 10–13 and 20–21: a zero position, a NaN
    # position, a zero velocity, a NaN MRP, a zero position again and a NaN velocity; at step 15 the true attitude
    # as its shadow MRP set (|σ| > 1, the same rotation) and at 17 a huge MRP (1e300: a rotation of ≈ 360°, the
    # body far off nadir). Before, each raised out of UpdateState and ended the simulation. Now the simulation
    # runs to its end; the bad states are dropped and counted per reason, each reason said once; the samples at
    # their times are measured from the states around them; the two MRP sets are rotations and read as such.
    def set_r(value):
        def edit(payload, time_ns):
            payload.r_BN_N = value
            return time_ns
        return edit

    def set_v(value):
        def edit(payload, time_ns):
            payload.v_BN_N = value
            return time_ns
        return edit

    def set_sigma(make):
        def edit(payload, time_ns):
            payload.sigma_BN = make(np.array(payload.sigma_BN))
            return time_ns
        return edit

    nan = math.nan
    edits = {10: set_r([0.0, 0.0, 0.0]), 11: set_r([nan, 7e6, 0.0]), 12: set_v([0.0, 0.0, 0.0]),
             13: set_sigma(lambda s: [nan, 0.0, 0.0]), 15: set_sigma(lambda s: -s / (s @ s)),
             17: set_sigma(lambda s: [1e300, 0.0, 0.0]), 20: set_r([0.0, 0.0, 0.0]), 21: set_v([0.0, nan, 0.0])}
    flight = Flight()
    writer = flight.add(StateWriter(edits), 90)
    writer.scStateInMsg.subscribeTo(flight.body.scStateOutMsg)
    written = flight.add(writer.scStateOutMsg.recorder(), 85)
    pmv = flight.add(pmv_on(writer.scStateOutMsg), 80)
    readings = pmv.recorder()
    flight.run(3.0)
    assert pmv.counters == {"rejected_state_implausible_orbit": 3, "rejected_state_non_finite": 3}
    assert said(capfd, "BSK_WARNING") == 2
    assert said.last.count("at 1.000 s dropped, implausible orbit (rejected_state_implausible_orbit counts them): "
                           "r_BN_N [0, 0, 0]") == 1
    assert said.last.count("at 1.100 s dropped, non finite (rejected_state_non_finite counts them): "
                           "r_BN_N [nan, 7e+06, 0]") == 1
    # Every sample of the 3 s, those at the dropped states' times measured between the states around them.
    assert np.array_equal(readings.times(), np.arange(31) * 100_000_000)
    assert readings.valid[np.arange(31) != 17].all()
    # 1e300 is a turn of ≈ 360° (the body's axes on N's): 6′ off the Hill frame the body keeps elsewhere.
    assert max(abs(readings.trueRoll_CO[17]), abs(readings.truePitch_CO[17])) > 1.0 * ARCMIN_RAD
    assert np.abs(np.delete(readings.trueRoll_CO, 17)).max() < 0.1 * ARCMIN_RAD
    # The runtime fed the states the writer wrote without the six dropped ones: the same.
    kept = np.setdiff1d(np.arange(written.size()), [10, 11, 12, 13, 20, 21])
    samples = replay_states(pmv.values, written.timesWritten()[kept], written.r_BN_N[kept], written.v_BN_N[kept],
                            written.sigma_BN[kept], DCM_CB_HILL)
    assert len(samples) == len(readings)
    assert largest_difference_arcmin(readings, samples) <= SAME_STATES_ARCMIN


def test_basilisk_guards_stamps_going_backwards_are_counted_and_said(capfd):
    # The writer stamps steps 20 and 21 a second earlier than Basilisk's time, and step 30 a day later. Before,
    # the module stopped until Basilisk's time passed the newest stamp again, saying nothing (after the day's
    # stamp, for a day). Now each is dropped and counted, said once; the states after them are read as before.
    back = {step: (lambda payload, time_ns: time_ns - 1_000_000_000) for step in (20, 21)}
    back[30] = lambda payload, time_ns: time_ns + 86_400_000_000_000
    flight = Flight()
    writer = flight.add(StateWriter(back), 90)
    writer.scStateInMsg.subscribeTo(flight.body.scStateOutMsg)
    pmv = flight.add(pmv_on(writer.scStateOutMsg), 80)
    readings = pmv.recorder()
    flight.run(4.0)
    assert pmv.counters == {"rejected_state_backwards": 2, "rejected_state_future_stamp": 1}
    assert said(capfd, "before the state read last (1.900000000 s): dropped (rejected_state_backwards") == 1
    assert "after Basilisk's time (3.000000000 s): dropped (rejected_state_future_stamp counts them)" in said.last
    # The samples at 2.0, 2.1 and 3.0 s come from the states around them; every one of the 4 s is there.
    assert np.array_equal(readings.times(), np.arange(41) * 100_000_000)


@pytest.mark.parametrize("rate_hz, dynamics_s, module_s, duration_s, count", [
    (10.0, 0.1, 0.2, 6.0, 61),     # was 5 Hz: only the samples on the module's calls
    (3.0, 0.1, 0.1, 30.0, 91),     # was 1 reading in 30 s: 1/3 s is on no 0.1 s step but every 3rd second
    (3.0, 0.01, 0.01, 3.0, 10),    # was 1 reading in 3 s
])
def test_basilisk_guards_a_sensor_rate_off_the_tasks_period_samples_on_its_own_grid(
        capfd, rate_hz, dynamics_s, module_s, duration_s, count):
    # Basilisk cannot tell a Python module its task's period, so nothing is checked at Reset: the module samples
    # at k / rate s whatever its task, from the states around each sample time, and says so once. The
    # readings against the runtime fed every state the spacecraft wrote (the module sees only those of its
    # calls, and feeds only those around a sample): within SAME_STATES_ARCMIN. The body turns about two axes
    # (0.05 °/s about the roll axis, and with the orbit), so an attitude interpolated across a state the module
    # did not see is not the state's (measured: 2e-5′ for 10 Hz in the 0.2 s task, 0′ where every state is read).
    flight = Flight(dynamics_step_s=dynamics_s, roll_rate_rad_s=math.radians(0.05))
    task = "dynamics" if module_s == dynamics_s else flight.task("pmv", module_s)
    pmv = flight.add(pmv_on(flight.body.scStateOutMsg, {"sensor.rate_hz": rate_hz}), 80, task)
    readings = pmv.recorder()
    flight.run(duration_s)
    expected_ns = np.round(np.arange(count) / rate_hz * 1e9).astype(np.int64)
    assert np.array_equal(readings.times(), expected_ns)
    assert said(capfd, "s: interpolated from both, reported") == 1
    states = flight.states
    samples = replay_states(pmv.values, states.timesWritten(), states.r_BN_N, states.v_BN_N, states.sigma_BN,
                            DCM_CB_HILL)
    assert len(samples) == count
    assert largest_difference_arcmin(readings, samples) <= SAME_STATES_ARCMIN
    assert pmv.counters == {}


def test_basilisk_guards_an_unlinked_state_input_or_a_bad_epoch_ends_the_run_with_one_bsk_error(capfd):
    # BSK_ERROR raises Basilisk's BasiliskError; out of a Python module's Reset, Basilisk prints it (with the
    # frames of the module) and InitializeSimulation raises a RuntimeError of SWIG's director.
    flight = Flight()
    flight.add(PmvHorizonSensor(KONDOR), 80)
    with pytest.raises(RuntimeError, match="_SysModel.Reset"):
        flight.run(1.0)
    assert said(capfd, "BasiliskError: pmvHorizonSensor: scStateInMsg is not linked") == 1
    for payload, reason in ((None, "epochInMsg is linked but was never written"),
                            (messaging.EpochMsgPayload(year=2013, month=13, day=1), "epochInMsg: ")):
        flight = Flight()
        pmv = flight.add(pmv_on(flight.body.scStateOutMsg), 80)
        epoch = messaging.EpochMsg() if payload is None else messaging.EpochMsg().write(payload)
        pmv.epochInMsg.subscribeTo(epoch)
        with pytest.raises(RuntimeError, match="_SysModel.Reset"):
            flight.run(1.0)
        assert said(capfd, f"BasiliskError: pmvHorizonSensor: {reason}") == 1


def test_basilisk_guards_a_bridge_with_an_input_not_linked_ends_the_run_with_one_bsk_error(capfd):
    flight = Flight()
    pmv = flight.add(pmv_on(flight.body.scStateOutMsg), 80)
    bridge = PmvAttitudeNav(DCM_CB_HILL)
    bridge.nadirInMsg.subscribeTo(pmv.nadirOutMsg)  # attInMsg and transInMsg left unlinked
    flight.add(bridge, 70)
    with pytest.raises(RuntimeError, match="_SysModel.Reset"):
        flight.run(1.0)
    assert said(capfd, "BasiliskError: pmvAttitudeNav: attInMsg is not linked") == 1


def bridge_flight(roll_rad: float, navigation_source=None):
    """A flight with simpleNav and the bridge (its yaw and rate from ``navigation_source``, or simpleNav's)."""
    flight = Flight(roll_rad=roll_rad)
    navigation = flight.add(simpleNav.SimpleNav(), 90)
    navigation.scStateInMsg.subscribeTo(flight.body.scStateOutMsg)
    bridge = PmvAttitudeNav(DCM_CB_HILL)
    bridge.attInMsg.subscribeTo(navigation_source or navigation.attOutMsg)
    bridge.transInMsg.subscribeTo(navigation.transOutMsg)
    return flight, navigation, bridge


def test_basilisk_guards_a_bridge_fed_by_a_sensor_in_no_task_is_flagged_not_zero(capfd):
    # The PMV is made and linked to the bridge but never added to a task; the body is 30′ off the vertical.
    # Before, the bridge reported roll 0′, pitch 0′. Now it passes simpleNav's attitude on, says once that no
    # reading came, and counts the steps.
    flight, navigation, bridge = bridge_flight(30.0 * ARCMIN_RAD)
    pmv = pmv_on(flight.body.scStateOutMsg)
    bridge.nadirInMsg.subscribeTo(pmv.nadirOutMsg)
    flight.add(bridge, 70)
    out = flight.add(bridge.attNavOutMsg.recorder(), 60)
    truth = flight.add(navigation.attOutMsg.recorder(), 60)
    flight.run(2.0)
    assert bridge.stepsWithoutReading == 21
    assert said(capfd, "no PMV reading on nadirInMsg at 0.000 s (is the sensor in a task") == 1
    assert np.array_equal(out.sigma_BN, truth.sigma_BN)
    states = flight.states
    roll = roll_pitch_yaw_from_quaternion(attitude_in_orbital(states.r_BN_N, states.v_BN_N, out.sigma_BN,
                                                              DCM_CB_HILL))[0]
    np.testing.assert_allclose(roll, 30.0 * ARCMIN_RAD, atol=0.5 * ARCMIN_RAD)


class Estimator(sysModel.SysModel):
    """A stand-in for a gyro-based attitude estimator: the true attitude turned by ``yaw_rad`` about the orbital
    vertical and tilted in roll by ``roll_rad``, with a body rate of its own, as a ``NavAttMsg``."""

    def __init__(self, yaw_rad: float, roll_rad: float, omega):
        super().__init__()
        self.scStateInMsg = messaging.SCStatesMsgReader()
        self.attOutMsg = messaging.NavAttMsg()
        self.yaw_rad, self.roll_rad, self.omega = yaw_rad, roll_rad, list(omega)

    def UpdateState(self, CurrentSimNanos):
        state = self.scStateInMsg()
        r, v = np.array(state.r_BN_N), np.array(state.v_BN_N)
        roll, pitch, yaw = roll_pitch_yaw_from_quaternion(attitude_in_orbital(r, v, state.sigma_BN, DCM_CB_HILL))
        payload = messaging.NavAttMsgPayload()
        payload.sigma_BN = sigma_from_roll_pitch_yaw(roll + self.roll_rad, pitch, yaw + self.yaw_rad, r, v,
                                                     DCM_CB_HILL)[0].tolist()
        payload.omega_BN_B = self.omega
        payload.timeTag = CurrentSimNanos * 1e-9
        self.attOutMsg.write(payload, CurrentSimNanos, self.moduleID)


def test_basilisk_guards_the_bridge_takes_yaw_and_rate_from_any_navattmsg():
    # The bridge's yaw and rate from an estimator whose yaw is 2° off and whose roll is 1° off: the output keeps
    # the estimator's yaw and rate and takes roll and pitch from the PMV (the estimator's roll error gone).
    estimator = Estimator(yaw_rad=math.radians(2.0), roll_rad=math.radians(1.0), omega=(1e-4, -2e-4, 1.1e-3))
    flight, navigation, bridge = bridge_flight(10.0 * ARCMIN_RAD, estimator.attOutMsg)
    estimator.scStateInMsg.subscribeTo(flight.body.scStateOutMsg)
    flight.add(estimator, 89)
    pmv = flight.add(pmv_on(flight.body.scStateOutMsg), 80)
    readings = pmv.recorder()
    bridge.nadirInMsg.subscribeTo(pmv.nadirOutMsg)
    flight.add(bridge, 70)
    out = flight.add(bridge.attNavOutMsg.recorder(), 60)
    flight.run(2.0)
    assert bridge.stepsWithoutReading == 0
    states = flight.states
    roll, pitch, yaw = roll_pitch_yaw_from_quaternion(attitude_in_orbital(states.r_BN_N, states.v_BN_N,
                                                                          out.sigma_BN, DCM_CB_HILL))
    true_yaw = roll_pitch_yaw_from_quaternion(attitude_in_orbital(states.r_BN_N, states.v_BN_N, states.sigma_BN,
                                                                  DCM_CB_HILL))[2]
    np.testing.assert_allclose(roll, readings.roll_CO, atol=1e-12)
    np.testing.assert_allclose(pitch, readings.pitch_CO, atol=1e-12)
    np.testing.assert_allclose(yaw - true_yaw, math.radians(2.0), atol=1e-12)
    assert np.array_equal(out.omega_BN_B, np.tile([1e-4, -2e-4, 1.1e-3], (21, 1)))
    np.testing.assert_allclose(out.timeTag, readings.times() * 1e-9)
