"""Kondor in Basilisk with the PMV in the attitude loop: measured against true roll and pitch, a plot.

The Kondor preset's orbit (500 km, 74.5°) flown by Basilisk with its Earth gravity including J2; nadir
pointing by Basilisk's own FSW, ``hillPoint`` → ``attTrackingError`` → ``mrpFeedback`` → external torque,
with the attitude error computed from the PMV's roll and pitch (yaw and body rate from simpleNav). The PMV is
pmv_ros's sensor module (``PmvHorizonSensor``) in the same 10 Hz task. The plot shows what the PMV measured
and where the body truly was: with the oblateness not compensated on board (the preset, as flown) the loop
holds the *measured* local vertical, so the true attitude follows minus the sensor's error.

    .venv/bin/python examples/basilisk_kondor.py [--orbits 1] [--compensation] [--out basilisk_kondor.png]

An orbit takes some 20 s (``--pointing truth`` flies the FSW on simpleNav instead; examples/basilisk_meteor.py
has the wiring written out without the scenario helper, on reaction wheels).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from pmv_ros.hosts.basilisk import kondor_scenario  # noqa: E402
from pmv_ros.hosts.basilisk.scenario import preset_orbit  # noqa: E402
from pmv_ros.physics.constants import ARCMIN_RAD  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", default=str(REPO / "config" / "kondor.yaml"))
    parser.add_argument("--orbits", type=float, default=1.0)
    parser.add_argument("--pointing", choices=["pmv", "truth"], default="pmv")
    parser.add_argument("--compensation", action="store_true", help="oblateness compensation on board")
    parser.add_argument("--out", default="basilisk_kondor.png")
    args = parser.parse_args()

    scenario = kondor_scenario(args.config, {"sensor.oblateness_compensation": args.compensation}, gravity="j2",
                               pointing=args.pointing)
    period_s = preset_orbit(scenario.pmv.values).period_s
    started = time.perf_counter()
    scenario.run(args.orbits * period_s)
    print(f"{args.orbits:g} orbit ({args.orbits * period_s:.0f} s, {len(scenario.readings)} steps) in "
          f"{time.perf_counter() - started:.0f} s")

    readings = scenario.readings
    minutes = readings.times() * 1e-9 / 60.0
    figure, axes = plt.subplots(2, 1, sharex=True, figsize=(10, 6.5))
    for ax, name, measured, true in ((axes[0], "roll", readings.roll_CO, readings.trueRoll_CO),
                                     (axes[1], "pitch", readings.pitch_CO, readings.truePitch_CO)):
        ax.plot(minutes, measured / ARCMIN_RAD, lw=0.6, color="tab:blue", label=f"PMV {name} (measured)")
        ax.plot(minutes, true / ARCMIN_RAD, lw=1.4, color="tab:red", label=f"true {name}")
        ax.set_ylabel(f"{name}, arcmin (REP-103)")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    axes[1].set_xlabel("time, min")
    loop = "PMV in the loop" if args.pointing == "pmv" else "FSW on truth"
    figure.suptitle(f"Kondor in Basilisk (J2), nadir by hillPoint → mrpFeedback, {loop}; on-board oblateness "
                    f"compensation {'on' if args.compensation else 'off'}", fontsize=10)
    figure.tight_layout()
    figure.savefig(args.out, dpi=110)
    print(f"plot: {args.out}")

    summary = scenario.monitor.summary()
    removed = "oblateness model removed" if summary.oblateness_removed else "as measured"
    print(f"monitor (sensed − star tracker, {removed}):")
    for channel in ("roll", "pitch", "meridional"):
        c = summary.channel(channel)
        harmonics = ", ".join(f"k={k} {a / ARCMIN_RAD:.2f}′" for k, a in sorted(c.harmonics_rad.items())[:3])
        print(f"  {channel:10s} mean {c.mean_rad / ARCMIN_RAD:+.2f}′  σ {c.sigma_rad / ARCMIN_RAD:.2f}′  "
              f"3σ {c.three_sigma_rad / ARCMIN_RAD:.2f}′  {harmonics}")


if __name__ == "__main__":
    main()
