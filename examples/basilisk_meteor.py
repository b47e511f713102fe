"""Meteor-M No.2 in Basilisk, nadir-pointed on reaction wheels by Basilisk's FSW through the PMV: a closed loop.

A scenario as a Basilisk user writes one (Basilisk's own helpers and modules throughout), with the PMV in the
attitude loop:

* dynamics — ``spacecraft`` with Earth gravity from ``simIncludeGravBody`` (J2 from Basilisk's constants, so no
  support-data download), three reaction wheels from ``simIncludeRW``, ``simpleNav``;
* sensing — pmv_ros's ``PmvHorizonSensor`` on the Meteor-M No.2 preset (``config/meteor_m2.yaml``: the
  8201-V4M at 10 Hz with the flight environment), and ``PmvAttitudeNav``, which makes a ``NavAttMsg`` of the
  PMV's measured local vertical with the yaw and rate of ``simpleNav``;
* FSW — ``hillPoint`` → ``attTrackingError`` → ``mrpFeedback`` → ``rwMotorTorque``;

all in one 0.1 s task. The orbit is the preset's (835 km, 98.8°, its node at the epoch). With the on-board
oblateness compensation off (as flown) the loop holds the local vertical the PMV measures, so the true pointing
error is minus the sensor's error, as much of it as the loop passes (physics.md §2.1).

    .venv/bin/python examples/basilisk_meteor.py [--orbits 1] [--compensation] [--out basilisk_meteor.png]

It prints the wall time of the run and the machine's load, and the true pointing error (roll, pitch and yaw of
the PMV's case frame in the orbital frame, after the loop settled).
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np
from Basilisk.architecture import astroConstants, messaging
from Basilisk.fswAlgorithms import attTrackingError, hillPoint, mrpFeedback, rwMotorTorque
from Basilisk.simulation import gravityEffector, reactionWheelStateEffector, simpleNav, spacecraft
from Basilisk.utilities import SimulationBaseClass, macros, orbitalMotion, simIncludeGravBody, simIncludeRW

from pmv_ros.hosts.basilisk import (DCM_CB_HILL, PmvAttitudeNav, PmvHorizonSensor, attitude_in_orbital,
                                    host_values, sigma_from_roll_pitch_yaw)
from pmv_ros.hosts.basilisk.scenario import preset_orbit
from pmv_ros.physics.attitude import roll_pitch_yaw_from_quaternion
from pmv_ros.physics.constants import ARCMIN_RAD

REPO = Path(__file__).resolve().parents[1]
PRESET = REPO / "config" / "meteor_m2.yaml"

#: The spacecraft: mass, kg, and inertia about the centre of mass, kg·m² (illustrative for a 2.7 t platform).
MASS_KG = 2700.0
INERTIA_KG_M2 = [2500.0, 0.0, 0.0, 0.0, 2200.0, 0.0, 0.0, 0.0, 1500.0]
#: mrpFeedback's gains: K (N·m per MRP) and P (N·m·s); for small angles ω² = K / (4 I) and 2ζω = P / I, so
#: ω 0.025–0.032 rad/s and ζ 0.8–1.0 over the three axes of this inertia; no integral term.
GAIN_K, GAIN_P = 6.0, 100.0
STEP_S = 0.1
#: Pointing statistics start after this long (the loop settles in a few 1/(ζω) ≈ 50 s).
SETTLE_S = 500.0


class MeteorScenario:
    """The simulation, built and initialised: :meth:`run` flies it, the recorders hold what it did."""

    def __init__(self, preset=PRESET, overrides: dict | None = None, *, pmv: bool = True, states_every_s=1.0):
        self.sim = sim = SimulationBaseClass.SimBaseClass()
        process = sim.CreateNewProcess("meteor")
        task = "control"
        process.addTask(sim.CreateNewTask(task, macros.sec2nano(STEP_S)))

        # The PMV first: its preset says where the spacecraft flies.
        self.pmv = PmvHorizonSensor(preset, overrides, dcm_CB=DCM_CB_HILL) if pmv else None
        orbit = preset_orbit(self.pmv.values if pmv else host_values(preset, overrides))

        self.spacecraft = body = spacecraft.Spacecraft()
        body.ModelTag = "meteorM2"
        body.hub.mHub = MASS_KG
        body.hub.IHubPntBc_B = np.reshape(INERTIA_KG_M2, (3, 3)).tolist()
        gravity = simIncludeGravBody.gravBodyFactory()
        earth = gravity.createEarth()
        earth.isCentralBody = True
        earth.gravityModel = j2_model(earth.mu, earth.radEquator)
        gravity.addBodiesTo(body)
        self.keep = [gravity, earth]

        elements = orbitalMotion.ClassicElements()  # the preset's circular orbit at the epoch
        elements.a, elements.e = orbit.radius_m, 0.0
        elements.i, elements.Omega = orbit.inclination_rad, float(orbit.raan(0.0))
        elements.omega, elements.f = 0.0, float(orbit.argument_of_latitude(0.0))
        r0, v0 = orbitalMotion.elem2rv(earth.mu, elements)
        body.hub.r_CN_NInit, body.hub.v_CN_NInit = list(r0), list(v0)
        body.hub.sigma_BNInit = sigma_from_roll_pitch_yaw(0.0, 0.0, 0.0, r0, v0, DCM_CB_HILL)[0].tolist()
        body.hub.omega_BN_BInit = [0.0, 0.0, float(np.linalg.norm(np.cross(r0, v0)) / np.dot(r0, r0))]
        sim.AddModelToTask(task, body, 100)

        wheels = simIncludeRW.rwFactory()
        for axis in np.eye(3):
            wheels.create("Honeywell_HR16", axis.tolist(), maxMomentum=50.0, Omega=500.0)
        self.wheels = reactionWheelStateEffector.ReactionWheelStateEffector()
        self.wheels.ModelTag = "wheels"
        wheels.addToSpacecraft(body.ModelTag, self.wheels, body)
        sim.AddModelToTask(task, self.wheels, 95)
        wheel_config = wheels.getConfigMessage()

        navigation = simpleNav.SimpleNav()
        navigation.ModelTag = "simpleNav"
        navigation.scStateInMsg.subscribeTo(body.scStateOutMsg)
        sim.AddModelToTask(task, navigation, 90)

        attitude_source = navigation.attOutMsg
        self.bridge = None
        if pmv:
            self.pmv.scStateInMsg.subscribeTo(body.scStateOutMsg)
            sim.AddModelToTask(task, self.pmv, 80)
            self.bridge = PmvAttitudeNav(DCM_CB_HILL)
            self.bridge.nadirInMsg.subscribeTo(self.pmv.nadirOutMsg)
            self.bridge.attInMsg.subscribeTo(navigation.attOutMsg)  # yaw and body rate
            self.bridge.transInMsg.subscribeTo(navigation.transOutMsg)  # the orbit, for the orbital frame
            sim.AddModelToTask(task, self.bridge, 75)
            attitude_source = self.bridge.attNavOutMsg

        guidance = hillPoint.hillPoint()
        guidance.ModelTag = "hillPoint"
        guidance.transNavInMsg.subscribeTo(navigation.transOutMsg)
        sim.AddModelToTask(task, guidance, 70)
        tracking = attTrackingError.attTrackingError()
        tracking.ModelTag = "attTrackingError"
        tracking.attNavInMsg.subscribeTo(attitude_source)
        tracking.attRefInMsg.subscribeTo(guidance.attRefOutMsg)
        sim.AddModelToTask(task, tracking, 65)
        vehicle = messaging.VehicleConfigMsg().write(messaging.VehicleConfigMsgPayload(ISCPntB_B=INERTIA_KG_M2))
        control = mrpFeedback.mrpFeedback()
        control.ModelTag = "mrpFeedback"
        control.K, control.P, control.Ki = GAIN_K, GAIN_P, -1.0
        control.guidInMsg.subscribeTo(tracking.attGuidOutMsg)
        control.vehConfigInMsg.subscribeTo(vehicle)
        control.rwParamsInMsg.subscribeTo(wheel_config)
        control.rwSpeedsInMsg.subscribeTo(self.wheels.rwSpeedOutMsg)
        sim.AddModelToTask(task, control, 60)
        torque = rwMotorTorque.rwMotorTorque()
        torque.ModelTag = "rwMotorTorque"
        torque.controlAxes_B = [1, 0, 0, 0, 1, 0, 0, 0, 1]
        torque.vehControlInMsg.subscribeTo(control.cmdTorqueOutMsg)
        torque.rwParamsInMsg.subscribeTo(wheel_config)
        self.wheels.rwMotorCmdInMsg.subscribeTo(torque.rwMotorTorqueOutMsg)
        sim.AddModelToTask(task, torque, 55)
        self.keep += [navigation, guidance, tracking, vehicle, control, torque, wheel_config]

        # Recorders, decimated: the spacecraft's states (the true pointing), the PMV's readings.
        self.states = body.scStateOutMsg.recorder(macros.sec2nano(states_every_s))
        sim.AddModelToTask(task, self.states, 50)
        self.readings = self.pmv.recorder(interval_s=states_every_s) if pmv else None
        sim.InitializeSimulation()

    def run(self, duration_s: float) -> float:
        """Fly to ``duration_s`` of simulation time; the wall time it took, s."""
        started = time.perf_counter()
        self.sim.ConfigureStopTime(macros.sec2nano(duration_s))
        self.sim.ExecuteSimulation()
        return time.perf_counter() - started

    def true_pointing(self):
        """Basilisk times (s) and the true roll, pitch and yaw (rad, REP-103) of the PMV's case frame in the
        orbital frame, from the recorded states."""
        states = self.states
        q = attitude_in_orbital(states.r_BN_N, states.v_BN_N, states.sigma_BN, DCM_CB_HILL)
        return (states.times() * 1e-9, *roll_pitch_yaw_from_quaternion(q))


def j2_model(mu_m3_s2: float, radius_m: float) -> gravityEffector.SphericalHarmonicsGravityModel:
    """Earth's zonal J2 (Basilisk's astroConstants) as a degree-2 spherical-harmonics model, fully normalised."""
    model = gravityEffector.SphericalHarmonicsGravityModel()
    model.muBody, model.radEquator, model.maxDeg = mu_m3_s2, radius_m, 2
    model.cBar = [[1.0], [0.0, 0.0], [-astroConstants.J2_EARTH / math.sqrt(5.0), 0.0, 0.0]]
    model.sBar = [[0.0], [0.0, 0.0], [0.0, 0.0, 0.0]]
    return model


def pointing_summary(t_s, roll, pitch, yaw, after_s: float = SETTLE_S) -> dict:
    """Mean, σ and largest |value| of the true roll, pitch and yaw after ``after_s``, arcmin."""
    kept = t_s >= after_s
    summary = {}
    for name, angle in (("roll", roll), ("pitch", pitch), ("yaw", yaw)):
        values = np.asarray(angle)[kept] / ARCMIN_RAD
        summary[name] = (float(values.mean()), float(values.std()), float(np.abs(values).max()))
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(PRESET))
    parser.add_argument("--orbits", type=float, default=1.0)
    parser.add_argument("--compensation", action="store_true", help="oblateness compensation on board")
    parser.add_argument("--out", default=None, help="a plot of the true pointing and the PMV's readings (PNG)")
    args = parser.parse_args()

    scenario = MeteorScenario(args.config, {"sensor.oblateness_compensation": args.compensation})
    duration_s = SETTLE_S + args.orbits * preset_orbit(scenario.pmv.values).period_s
    wall_s = scenario.run(duration_s)
    load = os.getloadavg()[0]
    print(f"{duration_s:.0f} s of simulation ({args.orbits:g} orbit after {SETTLE_S:.0f} s to settle, "
          f"{round(duration_s / STEP_S)} steps) in {wall_s:.1f} s of wall time, load {load:.2f}")
    t_s, roll, pitch, yaw = scenario.true_pointing()
    print(f"true pointing error after {SETTLE_S:.0f} s (case frame in the orbital frame, arcmin):")
    for name, (mean, sigma, largest) in pointing_summary(t_s, roll, pitch, yaw).items():
        print(f"  {name:5s} mean {mean:+7.3f}  σ {sigma:6.3f}  max |·| {largest:6.3f}")
    counters = scenario.pmv.counters
    print(f"PMV: {len(scenario.readings)} readings recorded (one a second), counters {counters or 'none'}; "
          f"bridge steps without a reading: {scenario.bridge.stepsWithoutReading}")
    if args.out:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        readings = scenario.readings
        minutes = readings.times() * 1e-9 / 60.0
        figure, axes = plt.subplots(2, 1, sharex=True, figsize=(10, 6))
        for ax, name, measured, true in ((axes[0], "roll", readings.roll_CO, readings.trueRoll_CO),
                                         (axes[1], "pitch", readings.pitch_CO, readings.truePitch_CO)):
            ax.plot(minutes, measured / ARCMIN_RAD, lw=0.6, label=f"PMV {name} (measured)")
            ax.plot(minutes, true / ARCMIN_RAD, lw=1.4, label=f"true {name}")
            ax.set_ylabel(f"{name}, arcmin")
            ax.grid(alpha=0.3)
            ax.legend(loc="upper right", fontsize=8)
        axes[1].set_xlabel("time, min")
        figure.suptitle("Meteor-M No.2 in Basilisk: hillPoint → mrpFeedback → reaction wheels through the PMV")
        figure.tight_layout()
        figure.savefig(args.out, dpi=110)
        print(f"plot: {args.out}")


if __name__ == "__main__":
    main()
