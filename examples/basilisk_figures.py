"""The figures of docs/basilisk.md: the PMV module against pmv_ros's own sensing, in a closed loop, with J2.

    .venv/bin/python examples/basilisk_figures.py [--config config/kondor.yaml] [--orbits 1] [--only same loop j2]

* ``same`` — one orbit flown by Basilisk (two-body gravity, nadir pointing by Basilisk's FSW on truth), the
  module sensing at each step: its readings and its monitor's statistics against the recorded states replayed
  through pmv_ros (``replay_states``, ``flight_summary``).
* ``loop`` — Basilisk's ``mrpFeedback`` fed the PMV's roll and pitch (yaw and rate from simpleNav): the true
  attitude against the oblateness model (physics.md §2.1), on-board compensation off and on, and the monitor's
  residual of the same run.
* ``j2`` — Basilisk's propagation with J2 against pmv_ros's own orbit, and what the difference does to the
  sensed angles: the preset's instrument and the geometric one (ideal detector, uniform radiance).

Each part prints its figures in arcminutes and metres.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from pmv_ros.analysis.statistics import harmonic_amplitudes
from pmv_ros.hosts.basilisk import (DCM_CB_HILL, attitude_in_orbital, host_values, kondor_scenario,
                                    sigma_from_roll_pitch_yaw)
from pmv_ros.hosts.basilisk.replay import flight_summary, replay_states
from pmv_ros.hosts.basilisk.scenario import GAINS, INERTIA_KG_M2, preset_orbit
from pmv_ros.physics.attitude import roll_pitch_yaw_from_quaternion
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.instrument.oblateness import closed_form_oblateness
from pmv_ros.physics.orbit.two_body import orbit_angles_from_state, orbital_frame_from_state

#: The closed loop's figures start after this much time (the loop settles in ≈ 3 × 34 s).
SETTLE_S = 300.0


def arcmin(x):
    return np.asarray(x) / ARCMIN_RAD


def oblateness_model(position, velocity):
    """The closed-form oblateness (physics.md §2.1; meridional, roll, pitch, rad) at ``(3, N)`` states."""
    u, inclination, altitude = orbit_angles_from_state(position, velocity)
    return closed_form_oblateness(u, altitude, inclination)


def recorded(scenario):
    """The spacecraft's recorded states: Basilisk times ns, r, v, sigma (N, 3)."""
    states = scenario.states
    return states.timesWritten(), states.r_BN_N, states.v_BN_N, states.sigma_BN


def summary_difference(a, b) -> float:
    """Largest difference of mean, σ and the harmonics over the channels of two monitor summaries, arcmin."""
    worst = 0.0
    for channel in ("roll", "pitch", "meridional"):
        ca, cb = a.channel(channel), b.channel(channel)
        pairs = [(ca.mean_rad, cb.mean_rad), (ca.sigma_rad, cb.sigma_rad)]
        pairs += [(ca.harmonics_rad[k], cb.harmonics_rad[k]) for k in ca.harmonics_rad]
        worst = max([worst] + [abs(x - y) for x, y in pairs if math.isfinite(x) or math.isfinite(y)])
    return worst / ARCMIN_RAD


def same(config: str, orbits: float) -> None:
    started = time.perf_counter()
    scenario = kondor_scenario(config, pointing="truth")
    period = preset_orbit(scenario.pmv.values).period_s
    scenario.run(orbits * period)
    flown = time.perf_counter() - started
    times, r, v, sigma = recorded(scenario)
    started = time.perf_counter()
    samples = replay_states(scenario.pmv.values, times, r, v, sigma, DCM_CB_HILL)
    replayed = time.perf_counter() - started
    readings = scenario.readings
    roll = np.array([s.roll_rad for s in samples])
    pitch = np.array([s.pitch_rad for s in samples])
    ok = len(samples) == len(readings)
    print(f"same: {len(readings)} readings (replay {len(samples)}), {flown:.0f} s flown, {replayed:.0f} s replayed")
    if ok:
        print(f"  max |module − replay|: roll {np.nanmax(abs(arcmin(roll - readings.roll_CO))):.3g}′, "
              f"pitch {np.nanmax(abs(arcmin(pitch - readings.pitch_CO))):.3g}′; "
              f"NaN alike: {np.array_equal(np.isnan(roll), np.isnan(readings.roll_CO))}")
    module, reference = scenario.monitor.summary(), flight_summary(scenario.pmv.values, samples)
    roll_stats, pitch_stats = module.channel("roll"), module.channel("pitch")
    print(f"  statistics: max |module − flight's| over mean, σ, harmonics: "
          f"{summary_difference(module, reference):.3g}′; roll mean {arcmin(roll_stats.mean_rad):.3f}′ "
          f"σ {arcmin(roll_stats.sigma_rad):.3f}′, pitch mean {arcmin(pitch_stats.mean_rad):.3f}′ "
          f"σ {arcmin(pitch_stats.sigma_rad):.3f}′, used {roll_stats.count}")


def loop_filter(axis: int, error, t):
    """What the loop makes of a sensor error series: the true angle about body axis ``axis`` that mrpFeedback
    (K, P; rates from simpleNav, the truth) settles to, −H(s)·error with H = (K/4) / (I s² + P s + K/4) for small
    angles."""
    from scipy.signal import lsim

    inertia = INERTIA_KG_M2[axis][axis]
    k, p = GAINS["K"], GAINS["P"]
    _, response, _ = lsim(([k / 4.0], [inertia, p, k / 4.0]), -np.asarray(error), t - t[0])
    return response


def loop(config: str, orbits: float, overrides: dict | None = None, label: str = "preset") -> None:
    """Closed loop through the PMV, compensation off and on; figures after the first SETTLE_S."""
    for compensation in (False, True):
        started = time.perf_counter()
        scenario = kondor_scenario(config, {**(overrides or {}), "sensor.oblateness_compensation": compensation},
                                   pointing="pmv")
        orbit = preset_orbit(scenario.pmv.values)
        scenario.run(SETTLE_S + orbits * orbit.period_s)
        readings = scenario.readings
        times, r, v, _ = recorded(scenario)
        t_all = readings.times() * 1e-9
        index = np.searchsorted(times, readings.times())
        _, model_roll, model_pitch = oblateness_model(r[index].T, v[index].T)
        summary = scenario.monitor.summary()
        keep = t_all >= SETTLE_S
        t = t_all[keep]
        phase = 2 * np.pi * t / orbit.period_s
        lost = int(np.count_nonzero(~readings.valid))
        print(f"loop/{label}/compensation {'on' if compensation else 'off'}: {len(readings)} readings, "
              f"{time.perf_counter() - started:.0f} s; figures from {SETTLE_S:.0f} s; readings with a lost pair "
              f"(the bridge keeps the one before): {lost}")
        for name, axis, k, true_all, model_all, sensed_all in (
                ("roll", 1, 1, readings.trueRoll_CO, model_roll, readings.roll_CO),
                ("pitch", 2, 2, readings.truePitch_CO, model_pitch, readings.pitch_CO)):
            error_all = sensed_all - true_all  # the sensor's whole error, sensed − true
            held = np.where(np.isfinite(error_all), error_all, 0.0)
            loop_model = loop_filter(axis, model_all, t_all)[keep]  # where the oblateness alone would take it
            loop_error = loop_filter(axis, held, t_all)[keep]  # where the whole error takes it
            true, model, error = true_all[keep], model_all[keep], error_all[keep]
            good = np.isfinite(error)
            amplitude = lambda x: float(arcmin(harmonic_amplitudes(phase[good], x[good], (k,))[0]))  # noqa: E731
            channel = summary.channel(name)
            rms = lambda x: float(arcmin(np.sqrt(np.mean(np.square(x)))))  # noqa: E731
            print(f"  {name}: true mean {arcmin(true.mean()):+.3f}′ rms {rms(true):.3f}′ "
                  f"k={k} {amplitude(true):.3f}′"
                  f" | oblateness model mean {arcmin(model.mean()):+.3f}′ k={k} {amplitude(model):.3f}′"
                  f" | true + model: mean {arcmin(np.mean(true + model)):+.3f}′ "
                  f"σ {arcmin(np.std(true + model)):.3f}′"
                  f" max {arcmin(abs(true + model).max()):.3f}′; through the loop (true − loop(−model)): "
                  f"max {arcmin(abs(true - loop_model).max()):.3f}′"
                  f" | true − loop(−sensor error) max {arcmin(abs(true - loop_error).max()):.4f}′"
                  f" | monitor (whole run, as it reports):"
                  f" mean {arcmin(channel.mean_rad):+.3f}′ σ {arcmin(channel.sigma_rad):.3f}′"
                  f" rms {arcmin(math.hypot(channel.mean_rad, channel.sigma_rad)):.3f}′")


def j2(config: str, orbits: float) -> None:
    for label, overrides in (("preset", {}), ("climatology only", {"environment.weather": False,
                                                                   "environment.height_variation": False}),
                             ("geometric", {"sensor.detector": "ideal", "radiance.source": "uniform"})):
        scenario = kondor_scenario(config, overrides, gravity="j2", pmv=False, pointing="truth")
        values = host_values(config, overrides)
        own = preset_orbit(values, j2_node_drift=True)
        scenario.run(orbits * own.period_s)
        times, r, v, sigma = recorded(scenario)
        t = times * 1e-9
        if label == "preset":
            for drift in (True, False):
                position, _ = preset_orbit(values, j2_node_drift=drift).state_eci(t)
                delta = r - position.T
                frame = orbital_frame_from_state(r.T, v.T)  # components along-track, normal, radial
                local = np.einsum("ijn,ni->nj", frame, delta)
                print(f"j2/orbit: Basilisk J2 − pmv_ros circular (j2_node_drift {drift}): max |Δr| "
                      f"{np.linalg.norm(delta, axis=1).max():.0f} m; max along {abs(local[:, 0]).max():.0f} m, "
                      f"normal {abs(local[:, 1]).max():.0f} m, radial {abs(local[:, 2]).max():.0f} m")
        position, velocity = own.state_eci(t)
        q = attitude_in_orbital(r, v, sigma, DCM_CB_HILL)  # the same attitude in each orbit's own frame
        roll, pitch, yaw = roll_pitch_yaw_from_quaternion(q)
        sigma_own = sigma_from_roll_pitch_yaw(roll, pitch, yaw, position.T, velocity.T, DCM_CB_HILL)
        flown = replay_states(values, times, r, v, sigma, DCM_CB_HILL)
        ours = replay_states(values, times, position.T, velocity.T, sigma_own, DCM_CB_HILL)
        d_roll = np.array([a.roll_rad - b.roll_rad for a, b in zip(flown, ours)])
        d_pitch = np.array([a.pitch_rad - b.pitch_rad for a, b in zip(flown, ours)])
        stamps = np.array([s.t_s for s in flown]) - 1.0
        index = np.searchsorted(t, stamps - 1e-6)
        _, roll_b, pitch_b = oblateness_model(r[index].T, v[index].T)
        _, roll_o, pitch_o = oblateness_model(position[:, index], velocity[:, index])
        # The same place rather than the same time: pmv_ros's orbit reaches Basilisk's argument of latitude
        # earlier or later (the along-track difference); its readings there, interpolated between samples.
        u_flown = np.unwrap(orbit_angles_from_state(r[index].T, v[index].T)[0])
        u_flown -= 2 * np.pi * np.round((u_flown[0] - own.arg_latitude_at_epoch_rad) / (2 * np.pi))
        there = own.time_of_argument_of_latitude(u_flown)
        own_t = stamps
        for name, d, model, a, b in (("roll", d_roll, roll_b - roll_o, flown, ours),
                                     ("pitch", d_pitch, pitch_b - pitch_o, flown, ours)):
            good = np.isfinite(d)
            sensed_own = np.array([getattr(x, f"{name}_rad") for x in b])
            sensed_flown = np.array([getattr(x, f"{name}_rad") for x in a])
            finite = np.isfinite(sensed_own)
            at_place = sensed_flown - np.interp(there, own_t[finite], sensed_own[finite])
            inside = good & (there >= own_t[0]) & (there <= own_t[-1])
            print(f"j2/{label} {name}: sensed on Basilisk's orbit − on pmv_ros's, same time: rms "
                  f"{arcmin(np.sqrt(np.mean(d[good] ** 2))):.4f}′ max {arcmin(abs(d[good]).max()):.4f}′; "
                  f"the oblateness model's change rms {arcmin(np.sqrt(np.mean(model[good] ** 2))):.4f}′, unexplained "
                  f"rms {arcmin(np.sqrt(np.mean((d - model)[good] ** 2))):.4f}′; same place (u): rms "
                  f"{arcmin(np.sqrt(np.mean(at_place[inside] ** 2))):.4f}′ (time shift up to "
                  f"{abs(there - stamps).max():.1f} s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default="config/kondor.yaml")
    parser.add_argument("--orbits", type=float, default=1.0)
    parser.add_argument("--only", nargs="*", default=["same", "loop", "j2"], choices=["same", "loop", "j2"])
    parser.add_argument("--loop-instruments", nargs="*", default=["geometric", "preset"],
                        choices=["geometric", "preset"], help="the closed loop with which instruments")
    args = parser.parse_args()
    geometric = {"sensor.detector": "ideal", "radiance.source": "uniform"}
    for part in args.only:
        if part != "loop":
            {"same": same, "j2": j2}[part](args.config, args.orbits)
            continue
        for instrument in args.loop_instruments:
            loop(args.config, args.orbits, geometric if instrument == "geometric" else {}, instrument)


if __name__ == "__main__":
    main()
