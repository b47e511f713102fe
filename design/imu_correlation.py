"""How long the sensor's roll and pitch errors stay correlated: what a filter taking ``/pmv/attitude_imu`` needs.

The Imu variances of each preset (``imu.roll_error_rms_arcmin``, ``imu.pitch_error_rms_arcmin``) are the root
mean square of the error, sensed − true with the oblateness kept, over a year's campaign. They are right on
average, but the error is not white: the horizon's radiance and height change over tens to hundreds of
kilometres of track, and the oblateness error runs twice per orbit. A filter that takes the 10 Hz samples as
independent believes the mean of a minute of samples to ≈ 1/√600 of the RMS, which it is not.

This script flies the campaign's ROS-free core (:func:`pmv_ros.runtime.flight.fly`: the nodes' own runtimes,
as ``pmv campaign`` flies a task) for each preset over several seeds and days, and measures, per preset and
axis, from the error's autocorrelation ρ(τ) about each flight's mean:

* ``tau_s``: the lag at which ρ has fallen from ρ(Δt) to ρ(Δt)/e (Δt the sample period): the time constant
  of a first-order Gauss–Markov process with the same fall;
* ``integral_s``: the integral time scale ∫ρ(τ)dτ over −τ₀ … τ₀, τ₀ the first zero of ρ: a mean of the
  samples over T seconds has the variance of T/``integral_s`` independent samples, so one sample per
  ``integral_s`` is the decimation at which taking samples as independent is right;
* ``white``: the share of the variance uncorrelated from one sample to the next, 1 − ρ(Δt);
* ``bias``: the share of the mean square that is the flight's mean (constant over a flight);
* ``oblateness``: the share of the mean square that the closed-form oblateness error (physics.md §2.1)
  carries, 1 − RMS²(error − oblateness)/RMS²(error) (negative where removing it makes the error larger).

Each for the error as the topic carries it (``kept``: oblateness in it, as none of the presets compensates it
on board) and with the closed-form oblateness removed (``removed``: what a filter that subtracts the model
of ``pmv oblateness`` sees). The oblateness is a known function of the argument of latitude with two
periods an orbit: its autocorrelation is periodic, not a decay, and where it dominates (``kept``) the
Gauss–Markov figures only summarise a quarter orbit.

    python design/imu_correlation.py                      # 3 presets × 6 seeds × 4 days, 2 orbits each
    python design/imu_correlation.py --presets kondor --seeds 2 --days 100 --orbits 1 --rate-hz 1   # quick
    python design/imu_correlation.py --json out.json      # every flight's figures as well

Prints one line per flight and a table per preset: the median over the flights and the range (min … max)
over seeds and days.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from pmv_ros.apps import campaign  # noqa: E402
from pmv_ros.physics.constants import ARCMIN_RAD  # noqa: E402
from pmv_ros.physics.instrument.oblateness import closed_form_oblateness  # noqa: E402
from pmv_ros.runtime.flight import OUTCOME_CODES, flight_values, fly  # noqa: E402
from pmv_ros.runtime.monitor.records import Status  # noqa: E402

PRESETS = ("kondor", "meteor_m2", "meteor_m2_2")
#: Days of year flown: the middle of each season, none of the days the presets' Imu figures were taken on
#: (1, 31, …, 361).
DAYS = (46, 137, 228, 319)
#: Longest lag of the autocorrelation, s: about half an orbit (the orbits here last 94–102 min).
MAX_LAG_S = 2800.0


def autocorrelation(values: np.ndarray, valid: np.ndarray, max_lag: int) -> np.ndarray:
    """ρ(k), k = 0 … max_lag, of ``values`` about their mean over the ``valid`` samples (others left out).

    Each lag's products are averaged over the pairs where both samples are valid (a lost sample removes its
    pairs, it does not count as zero).
    """
    x = np.where(valid, values - values[valid].mean(), 0.0)
    m = valid.astype(float)
    size = 1 << int(math.ceil(math.log2(2 * x.size)))
    spectrum_x, spectrum_m = np.fft.rfft(x, size), np.fft.rfft(m, size)
    products = np.fft.irfft(spectrum_x * np.conj(spectrum_x), size)[:max_lag + 1]
    pairs = np.fft.irfft(spectrum_m * np.conj(spectrum_m), size)[:max_lag + 1]
    covariance = products / np.maximum(np.round(pairs), 1.0)
    return covariance / covariance[0]


def correlation_figures(values: np.ndarray, valid: np.ndarray, dt_s: float) -> dict:
    """The figures of the module docstring for one channel of one flight (``tau_s`` NaN if ρ never falls)."""
    rho = autocorrelation(values, valid, int(round(MAX_LAG_S / dt_s)))
    lags_s = np.arange(rho.size) * dt_s
    first = rho[1]
    below = np.flatnonzero(rho[1:] < first / math.e)
    tau = lags_s[1 + below[0]] if below.size else math.nan
    zero = np.flatnonzero(rho <= 0.0)
    stop = zero[0] if zero.size else rho.size
    integral = dt_s * (2.0 * rho[:stop].sum() - rho[0])
    mean = values[valid].mean()
    mean_square = np.mean(values[valid] ** 2)
    return {"rms_arcmin": math.sqrt(mean_square) / ARCMIN_RAD, "bias": float(mean ** 2 / mean_square),
            "white": float(1.0 - first), "tau_s": float(tau), "integral_s": float(integral)}


def flight_figures(preset: str, seed: int, day: int, orbits: float, rate_hz: float | None) -> dict:
    """Fly one preset on one day with one seed; the figures per channel, oblateness kept and removed."""
    document = yaml.safe_load((ROOT / "config" / f"{preset}.yaml").read_text())
    document["error_monitor_node"]["ros__parameters"]["remove_oblateness"] = False  # the error as sensed
    epoch_utc = document["sensor_node"]["ros__parameters"]["sim"]["epoch_utc"]
    settings = campaign.Settings(document, epoch_utc, rate_hz, orbits)
    values = flight_values(document, campaign.task_overrides(settings, campaign.Task(day, seed)))
    flight = fly(values, campaign.task_samples(values, orbits))
    assert not flight.summary.oblateness_removed
    valid = flight.outcome == OUTCOME_CODES.index(Status.OK)
    dt_s = 1.0 / values.sensor["sensor.rate_hz"]
    sensor = values.sensor
    _, oblate_roll, oblate_pitch = closed_form_oblateness(
        flight.u_rad, sensor["orbit.altitude_km"] * 1e3, math.radians(sensor["orbit.inclination_deg"]))
    figures = {}
    for channel, oblate in (("roll", oblate_roll), ("pitch", oblate_pitch)):
        error = getattr(flight, f"{channel}_rad")
        ok = valid & np.isfinite(error)
        kept, removed = correlation_figures(error, ok, dt_s), correlation_figures(error - oblate, ok, dt_s)
        kept["oblateness"] = removed["oblateness"] = 1.0 - (removed["rms_arcmin"] / kept["rms_arcmin"]) ** 2
        figures[f"{channel} kept"], figures[f"{channel} removed"] = kept, removed
    return figures


def summarise(rows: list[dict]) -> dict:
    """Per channel and figure: (median, min, max) over the flights."""
    summary = {}
    for channel in rows[0]["figures"]:
        summary[channel] = {}
        for name in rows[0]["figures"][channel]:
            values = np.array([row["figures"][channel][name] for row in rows], float)
            finite = values[np.isfinite(values)]
            summary[channel][name] = ((float(np.median(finite)), float(finite.min()), float(finite.max()))
                                      if finite.size else (math.nan,) * 3) + (int(values.size - finite.size),)
    return summary


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", nargs="+", default=list(PRESETS))
    parser.add_argument("--seeds", type=int, default=6, help="seeds 1 … N (default 6)")
    parser.add_argument("--days", type=int, nargs="+", default=list(DAYS),
                        help="days of year (default " + " ".join(map(str, DAYS)) + ")")
    parser.add_argument("--orbits", type=float, default=2.0, help="orbits per flight (default 2)")
    parser.add_argument("--rate-hz", type=float, default=None, help="sensor rate (default: the preset's, 10 Hz)")
    parser.add_argument("--json", type=Path, default=None, help="write every flight's figures and the summary here")
    args = parser.parse_args(argv)

    results = {}
    for preset in args.presets:
        rows = []
        for day in args.days:
            for seed in range(1, args.seeds + 1):
                started = time.perf_counter()
                figures = flight_figures(preset, seed, day, args.orbits, args.rate_hz)
                rows.append({"day": day, "seed": seed, "figures": figures})
                print(f"{preset} day {day} seed {seed} ({time.perf_counter() - started:.0f} s): " + "; ".join(
                    f"{channel} τ {f['tau_s']:.0f} s ∫ {f['integral_s']:.0f} s" for channel, f in figures.items()),
                    flush=True)
        results[preset] = {"flights": rows, "summary": summarise(rows)}
        print(f"\n{preset}: median (min … max) over {len(rows)} flights "
              f"({args.seeds} seeds × days {', '.join(map(str, args.days))}, {args.orbits:g} orbits each)")
        columns = (("rms_arcmin", 2, "RMS ′"), ("oblateness", 2, "oblateness share"), ("bias", 2, "bias share"),
                   ("white", 3, "white share"), ("tau_s", 0, "τ s"), ("integral_s", 0, "∫ρ s"))
        print(f"{'error':<16}" + "".join(f"{title:>22}" for _, _, title in columns))
        for channel, figures in results[preset]["summary"].items():
            cells = []
            for name, digits, _ in columns:
                median, low, high, missing = figures[name]
                cells.append(f"{median:.{digits}f} ({low:.{digits}f}…{high:.{digits}f})"
                             + (f" {missing}×∞" if missing else ""))
            print(f"{channel:<16}" + "".join(f"{cell:>22}" for cell in cells))
        print(flush=True)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
