"""A spacecraft on a preset's orbit in Basilisk, pointed at nadir by Basilisk's own FSW, with the PMV on board.

What the example (``examples/basilisk_kondor.py``), the tests and the
figures of docs/basilisk.md fly. One task at the step
``step_s`` runs, in this order: the spacecraft (Basilisk's integrator,
Earth gravity: a point mass of pmv_ros's GM, or with pmv_ros's J2 on GRS80's
equatorial radius — set from constants, no gravity file), ``simpleNav``
(no noise: the truth), the PMV and its navigation bridge, ``hillPoint`` →
``attTrackingError`` → ``mrpFeedback`` → the external torque. ``pointing``
says what the attitude error is computed from: ``simpleNav``'s attitude
(``"truth"``) or the PMV's roll and pitch with ``simpleNav``'s yaw and rate
(``"pmv"``, :class:`~pmv_ros.hosts.basilisk.nav.PmvAttitudeNav`).

The spacecraft starts on the preset's circular orbit (its elements at the
epoch, as pmv_ros's own orbit model places it) on the Hill frame, turning
with it; the PMV's case frame is the Hill frame's axes 2, 3, 1
(:data:`~pmv_ros.hosts.basilisk.frames.DCM_CB_HILL`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timezone

from Basilisk.architecture import messaging
from Basilisk.fswAlgorithms import attTrackingError, hillPoint, mrpFeedback
from Basilisk.simulation import extForceTorque, gravityEffector, simpleNav, spacecraft
from Basilisk.utilities import SimulationBaseClass, macros

from ...physics.constants import GM_EARTH_M3_S2, GRS80, J2_EARTH
from ...runtime.common.assembly import build_models, parse_epoch
from .frames import DCM_CB_HILL, sigma_from_roll_pitch_yaw
from .nav import PmvAttitudeNav
from .sensor import PmvHorizonSensor
from .values import host_values

#: Mass, kg, and inertia about the centre of mass, kg·m², of the spacecraft (Basilisk's attitude-scenario hub).
MASS_KG = 750.0
INERTIA_KG_M2 = ((900.0, 0.0, 0.0), (0.0, 800.0, 0.0), (0.0, 0.0, 600.0))
#: mrpFeedback gains (Basilisk's attitude-feedback scenario): K, N·m per MRP; P, N·m·s; no integral term.
GAINS = {"K": 3.5, "P": 30.0, "Ki": -1.0}

#: Task priorities: a higher one runs first within the step.
_ORDER = ("spacecraft", "states", "navigation", "pmv", "pmv_nav", "guidance", "tracking", "control", "torque")


def earth_gravity(j2: bool) -> gravityEffector.GravBodyData:
    """The central Earth: pmv_ros's GM; with ``j2``, the zonal J2 of pmv_ros on GRS80's equatorial radius."""
    earth = gravityEffector.GravBodyData()
    earth.planetName = "earth_planet_data"
    earth.isCentralBody = True
    earth.mu = GM_EARTH_M3_S2
    earth.radEquator = GRS80.a_m
    if j2:
        model = gravityEffector.SphericalHarmonicsGravityModel()
        model.muBody = GM_EARTH_M3_S2
        model.radEquator = GRS80.a_m
        model.maxDeg = 2
        model.cBar = [[1.0], [0.0, 0.0], [-J2_EARTH / math.sqrt(5.0), 0.0, 0.0]]  # fully normalised C20
        model.sBar = [[0.0], [0.0, 0.0], [0.0, 0.0, 0.0]]
        earth.gravityModel = model
    return earth


def preset_orbit(values, j2_node_drift: bool | None = None):
    """pmv_ros's own orbit of the preset (its circular orbit at the epoch, Basilisk's time 0), optionally with the
    secular J2 drift switched on or off."""
    sensor = dict(values.sensor, **{"orbit.source": "circular", "attitude.source": "profile",
                                    "sensor.detector": "ideal", "sim.fast_time": True, "sim.start_time_s": 0.0})
    if j2_node_drift is not None:
        sensor["orbit.j2_node_drift"] = j2_node_drift
    orbit, _, _ = build_models(sensor, correction=None)
    return orbit


def epoch_message(values) -> messaging.EpochMsg:
    """Basilisk's ``EpochMsg`` of the preset's ``sim.epoch_utc`` (checked as the sensor checks it)."""
    parse_epoch(values.sensor["sim.epoch_utc"])
    moment = datetime.fromisoformat(values.sensor["sim.epoch_utc"].strip())
    moment = moment.replace(tzinfo=timezone.utc) if moment.tzinfo is None else moment.astimezone(timezone.utc)
    payload = messaging.EpochMsgPayload()
    payload.year, payload.month, payload.day = moment.year, moment.month, moment.day
    payload.hours, payload.minutes = moment.hour, moment.minute
    payload.seconds = moment.second + moment.microsecond * 1e-6
    return messaging.EpochMsg().write(payload)


@dataclass
class Scenario:
    """A built simulation: run it with :meth:`run`, then read the recorders."""

    sim: SimulationBaseClass.SimBaseClass
    spacecraft: spacecraft.Spacecraft
    states: object  #: recorder of the spacecraft's states at every step
    pmv: PmvHorizonSensor | None
    readings: object | None  #: the PMV's recorder (every reading)
    monitor: object | None  #: the PMV's error monitor
    step_s: float
    nav: PmvAttitudeNav | None = None  #: the PMV's NavAttMsg bridge (pointing "pmv")
    keep: list = field(default_factory=list, repr=False)  # modules and messages Basilisk does not own

    def run(self, duration_s: float) -> None:
        """Fly from the start (or where the last run stopped) to ``duration_s`` of Basilisk time."""
        self.sim.ConfigureStopTime(macros.sec2nano(duration_s))
        self.sim.ExecuteSimulation()


def kondor_scenario(preset, overrides: dict | None = None, *, gravity: str = "two_body", pointing: str = "truth",
                    pmv: bool = True, step_s: float = 0.1, extra: tuple = ()) -> Scenario:
    """A spacecraft on the preset's orbit, nadir-pointed by Basilisk's FSW, with the PMV.

    Args:
        preset, overrides: the PMV's parameters (:class:`PmvHorizonSensor`); the orbit is the preset's too.
        gravity: ``"two_body"`` or ``"j2"``.
        pointing: the attitude error from ``simpleNav``'s ``"truth"`` or from the ``"pmv"`` (needs ``pmv``).
        pmv: the PMV on board (False: the scenario without it, a baseline).
        step_s: the step of the task (dynamics, FSW, the PMV), s.
        extra: further modules for the task, run where the PMV runs (each with ``scStateInMsg`` subscribed).
    """
    if gravity not in ("two_body", "j2") or pointing not in ("truth", "pmv"):
        raise ValueError(f"gravity, pointing = {gravity!r}, {pointing!r}: not one of the choices")
    if pointing == "pmv" and not pmv:
        raise ValueError("pointing = 'pmv' closes the loop through the PMV: pmv = True")
    sim = SimulationBaseClass.SimBaseClass()
    process = sim.CreateNewProcess("process")
    process.addTask(sim.CreateNewTask("dynamics", macros.sec2nano(step_s)))
    priority = {name: 100 - 10 * k for k, name in enumerate(_ORDER)}
    keep = []

    sensor = PmvHorizonSensor(preset, overrides, dcm_CB=DCM_CB_HILL) if pmv else None
    values = sensor.values if sensor else host_values(preset, overrides)
    orbit = preset_orbit(values)
    r0, v0 = orbit.state_eci(0.0)

    body = spacecraft.Spacecraft()
    body.ModelTag = "kondor"
    body.hub.mHub = MASS_KG
    body.hub.IHubPntBc_B = [list(row) for row in INERTIA_KG_M2]
    body.hub.r_CN_NInit = r0.tolist()
    body.hub.v_CN_NInit = v0.tolist()
    body.hub.sigma_BNInit = sigma_from_roll_pitch_yaw(0.0, 0.0, 0.0, r0, v0, DCM_CB_HILL)[0].tolist()
    body.hub.omega_BN_BInit = [0.0, 0.0, orbit.mean_motion_rad_s]  # turning with the Hill frame (about B3)
    earth = earth_gravity(gravity == "j2")
    body.gravField.gravBodies = spacecraft.GravBodyVector([earth])
    keep.append(earth)
    sim.AddModelToTask("dynamics", body, priority["spacecraft"])
    states = body.scStateOutMsg.recorder()
    sim.AddModelToTask("dynamics", states, priority["states"])

    navigation = simpleNav.SimpleNav()
    navigation.ModelTag = "simpleNav"
    navigation.scStateInMsg.subscribeTo(body.scStateOutMsg)
    sim.AddModelToTask("dynamics", navigation, priority["navigation"])

    readings = monitor = bridge = None
    attitude_source = navigation.attOutMsg
    if sensor is not None:
        sensor.scStateInMsg.subscribeTo(body.scStateOutMsg)
        epoch = epoch_message(values)
        sensor.epochInMsg.subscribeTo(epoch)
        keep.append(epoch)
        readings, monitor = sensor.recorder(), sensor.errorMonitor()
        sim.AddModelToTask("dynamics", sensor, priority["pmv"])
        if pointing == "pmv":
            bridge = PmvAttitudeNav(DCM_CB_HILL)
            bridge.nadirInMsg.subscribeTo(sensor.nadirOutMsg)
            bridge.attInMsg.subscribeTo(navigation.attOutMsg)
            bridge.transInMsg.subscribeTo(navigation.transOutMsg)
            sim.AddModelToTask("dynamics", bridge, priority["pmv_nav"])
            attitude_source = bridge.attNavOutMsg

    for module in extra:
        module.scStateInMsg.subscribeTo(body.scStateOutMsg)
        sim.AddModelToTask("dynamics", module, priority["pmv"])

    guidance = hillPoint.hillPoint()
    guidance.ModelTag = "hillPoint"
    guidance.transNavInMsg.subscribeTo(navigation.transOutMsg)
    sim.AddModelToTask("dynamics", guidance, priority["guidance"])
    tracking = attTrackingError.attTrackingError()
    tracking.ModelTag = "attTrackingError"
    tracking.attNavInMsg.subscribeTo(attitude_source)
    tracking.attRefInMsg.subscribeTo(guidance.attRefOutMsg)
    sim.AddModelToTask("dynamics", tracking, priority["tracking"])
    vehicle = messaging.VehicleConfigMsg().write(messaging.VehicleConfigMsgPayload(
        ISCPntB_B=[c for row in INERTIA_KG_M2 for c in row]))
    keep.append(vehicle)
    control = mrpFeedback.mrpFeedback()
    control.ModelTag = "mrpFeedback"
    control.guidInMsg.subscribeTo(tracking.attGuidOutMsg)
    control.vehConfigInMsg.subscribeTo(vehicle)
    control.K, control.P, control.Ki = GAINS["K"], GAINS["P"], GAINS["Ki"]
    sim.AddModelToTask("dynamics", control, priority["control"])
    torque = extForceTorque.ExtForceTorque()
    torque.ModelTag = "externalTorque"
    torque.cmdTorqueInMsg.subscribeTo(control.cmdTorqueOutMsg)
    body.addDynamicEffector(torque)
    sim.AddModelToTask("dynamics", torque, priority["torque"])
    keep += [navigation, guidance, tracking, control, torque]

    sim.InitializeSimulation()
    return Scenario(sim, body, states, sensor, readings, monitor, step_s, bridge, keep)
