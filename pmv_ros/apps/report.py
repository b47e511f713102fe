"""Report of a simulated run: final statistics as JSON and the plots a user looks at.

Plots (PNG, matplotlib's Agg backend, no display needed):

* ``residuals.png`` — roll and pitch residual (sensor − star tracker, arcmin)
  against the argument of latitude, with the closed-form oblateness model
  drawn over them, like the figures of the flight-test papers;
* ``spectrum.png`` — amplitude of the residual at each harmonic k of the
  orbital frequency (least squares over the whole record), with the monitor's
  live k = 1, 2, 15–25 values marked (physics.md §5.1), and — when the preset
  names a flight record (``sim.flight_record``) — the record's published
  points beside it (:func:`flight_record`, pmv_ros/data/flight_records.json);
* ``tracker.png`` (when the run's star-tracker frames are given) — the ground
  track, with the frames that gave no attitude marked by the tracker's reason
  (where the South Atlantic Anomaly, the star-poor sky and the Sun near the
  boresight are), and what each reason cost the run (``truth_lost``).
* ``pointing.png`` (a closed-loop run) — the true pointing error (the body's roll and pitch against nadir)
  against the argument of latitude, with minus the closed-form oblateness drawn over it when the sensor
  does not compensate it on board: the attitude the loop settles to (physics.md §2.1).
"""

from __future__ import annotations

import json
import math
from importlib import resources
from pathlib import Path

import numpy as np

from ..analysis.statistics import HarmonicFit, fit_harmonics
from ..physics.constants import ARCMIN_RAD
from ..storage.json_output import finite_json
from ..physics.instrument.oblateness import closed_form_oblateness


def spectrum_fit(t_s, values, period_s: float, max_k: int = 40) -> HarmonicFit:
    """Harmonics k = 1 … max_k of 1/period over the whole record (:func:`~pmv_ros.analysis.statistics.fit_harmonics`:
    least squares on the samples there are, the §5.1 harmonics fitted together and every other k with them;
    a k the record's gaps leave undetermined is pending, NaN, with the reason)."""
    t = np.asarray(t_s, float)
    return fit_harmonics(2.0 * np.pi * t / period_s, np.asarray(values, float), np.arange(1, max_k + 1))


def harmonic_spectrum(t_s, values, period_s: float, max_k: int = 40):
    """``(k, amplitude)`` of :func:`spectrum_fit` (units of ``values``; NaN where pending)."""
    fit = spectrum_fit(t_s, values, period_s, max_k)
    return np.arange(1, max_k + 1), fit.amplitude


def flight_record(name: str) -> dict | None:
    """The published points of a named flight record: ``{"title", "pitch": {k: ′}, "roll": {k: ′}}``; None for "".

    ValueError for a name that pmv_ros/data/flight_records.json does not hold.
    """
    if not name:
        return None
    records = json.loads(resources.files("pmv_ros").joinpath("data", "flight_records.json").read_text("utf-8"))
    if name not in records["records"]:
        raise ValueError(f"flight record {name!r} is not one of {sorted(records['records'])}")
    return records["records"][name]


def channel_to_dict(channel) -> dict:
    """One channel's statistics (:class:`~pmv_ros.analysis.statistics.ChannelStatistics`) as JSON-ready data,
    arcmin and m for people: the one layout of every report and budget."""
    return {
        "count": channel.count,
        "mean_arcmin": channel.mean_rad / ARCMIN_RAD,
        "sigma_arcmin": channel.sigma_rad / ARCMIN_RAD,
        "three_sigma_arcmin": channel.three_sigma_rad / ARCMIN_RAD,
        "limit_low_arcmin": channel.limit_low_rad / ARCMIN_RAD,
        "limit_high_arcmin": channel.limit_high_rad / ARCMIN_RAD,
        "max_abs_arcmin": channel.max_abs_rad / ARCMIN_RAD,
        "harmonics_arcmin": {str(k): v / ARCMIN_RAD for k, v in sorted(channel.harmonics_rad.items())},
        "harmonics_pending": channel.harmonics_pending,
        "ground_sigma_m": channel.ground_sigma_m,
        "ground_max_abs_m": channel.ground_max_abs_m,
    }


def statistics_to_dict(statistics) -> dict:
    """Final statistics (a shim ErrorStatistics or a monitor summary) as plain JSON-ready data."""
    return {"oblateness_removed": statistics.oblateness_removed,
            "channels": {channel.channel: channel_to_dict(channel) for channel in statistics.channels},
            "counters": dict(statistics.counters)}


def truth_lost_summary(truth_lost: dict, samples: int) -> dict:
    """What each star-tracker reason cost a run: ``{reason: {"samples": n, "share": n / samples}}`` for the reasons
    that cost any (``truth_lost`` the monitor's ``truth_lost_<reason>`` counters; ``samples`` the sensor samples)."""
    return {key[len("truth_lost_"):]: {"samples": int(count), "share": count / samples if samples else math.nan}
            for key, count in truth_lost.items() if count}


def pointing_to_dict(controller, oblateness_compensation: bool) -> dict:
    """The true pointing error of a closed loop (a :class:`~pmv_ros.runtime.control.ControllerRuntime`) as
    JSON-ready data: per axis the layout of :func:`channel_to_dict`, and what the figures depend on."""
    roll, pitch = controller.pointing.channels()
    gains = controller.settings.gains
    return {"note": "true roll and pitch of the body against nadir (REP-103), after the loop's settling time",
            "roll": channel_to_dict(roll), "pitch": channel_to_dict(pitch),
            "settling_time_s": controller.settings.settling_time_s,
            "transient_samples": controller.pointing.skipped,
            "bandwidth_hz": gains.bandwidth_hz, "damping_ratio": gains.damping_ratio,
            "oblateness_compensation": bool(oblateness_compensation)}


def write_report(directory, summary: dict, residuals: np.ndarray, orbit, live_harmonics: dict | None = None,
                 record: dict | None = None, tracker: dict | None = None, pointing: np.ndarray | None = None) -> dict:
    """Write ``statistics.json``, ``residuals.png`` and ``spectrum.png`` into ``directory`` (``tracker.png`` when
    the star tracker's frames are given, ``pointing.png`` for a closed loop).

    Returns the summary as written: the input plus ``residual_spectrum_arcmin``
    (whole-record harmonics, oblateness kept) and ``report_files``.

    Args:
        directory: output folder (created).
        summary: JSON-ready run summary (see ``pmv simulate``).
        residuals: ``(3, N)`` stamp (s), roll and pitch residual (rad).
        orbit: the :class:`~pmv_ros.physics.orbit.two_body.CircularOrbit` flown (for u and the model).
        live_harmonics: {channel: {k: amplitude_arcmin}} from the monitor, marked on the spectrum.
        record: a flight record (:func:`flight_record`) whose published points are drawn on the spectrum.
        tracker: the star tracker's frames along the ground track, for ``tracker.png``: ``track_deg`` (latitude,
            longitude ``(N,)`` deg of the run), ``frames_deg`` (latitude, longitude ``(K,)`` of the frames without
            attitude), ``reasons`` ``(K,)`` their reasons, and the run's ``truth_lost`` (:func:`truth_lost_summary`).
        pointing: ``(3, N)`` stamp (s), true roll and pitch (rad) of a closed loop, with ``summary["pointing"]``
            (:func:`pointing_to_dict`); None for an open loop.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "statistics.json", out / "residuals.png", out / "spectrum.png"]
    if tracker is not None:
        paths.append(out / "tracker.png")
    if pointing is not None:
        paths.append(out / "pointing.png")
    t, roll, pitch = residuals
    fits = {name: spectrum_fit(t, values, orbit.period_s) for name, values in (("roll", roll), ("pitch", pitch))}
    spectra = {name: (np.arange(1, fit.amplitude.size + 1), fit.amplitude) for name, fit in fits.items()}
    summary = dict(summary, residual_spectrum_arcmin={
        "note": "sensor − star tracker over the whole record, oblateness kept; amplitude at k = 1 … 40 "
                "(null: pending, see pending)",
        **{name: {int(k): float(a / ARCMIN_RAD) for k, a in zip(*spectrum)} for name, spectrum in spectra.items()},
        "pending": {name: fit.pending_note for name, fit in fits.items()},
        "largest_hole_deg": {name: math.degrees(fit.largest_hole_rad) for name, fit in fits.items()}},
        report_files=[str(p) for p in paths])
    # Strict JSON: NaN (e.g. harmonics before a full orbit) becomes null, as in `--json` output.
    paths[0].write_text(json.dumps(finite_json(summary), indent=2, default=_json_default, allow_nan=False) + "\n")

    u_deg = np.degrees(np.mod(orbit.argument_of_latitude(t), 2.0 * math.pi))
    model_u = np.linspace(0.0, 2.0 * math.pi, 721)
    _, model_roll, model_pitch = closed_form_oblateness(model_u, orbit.altitude_m, orbit.inclination_rad)
    figure, axes = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    for axis, values, model, name in ((axes[0], roll, model_roll, "roll"), (axes[1], pitch, model_pitch, "pitch")):
        axis.plot(u_deg, values / ARCMIN_RAD, ".", markersize=1.5, alpha=0.5,
                  label=f"{name} residual (sensor − star tracker)")
        axis.plot(np.degrees(model_u), model / ARCMIN_RAD, "k-", linewidth=1.5,
                  label="oblateness model (physics.md §2.1)")
        axis.set_ylabel(f"{name}, arcmin")
        axis.grid(True, alpha=0.3)
        axis.legend(loc="best", fontsize=8, framealpha=0.9)
    axes[1].set_xlabel("argument of latitude u, deg")
    axes[1].set_xlim(0, 360)
    figure.suptitle(f"PMV residuals, H = {orbit.altitude_m / 1e3:g} km, i = {math.degrees(orbit.inclination_rad):g}°")
    figure.tight_layout()
    figure.savefig(paths[1], dpi=110)
    plt.close(figure)

    figure, axis = plt.subplots(figsize=(9, 4.5))
    colours = {}
    for name, marker in (("roll", "o"), ("pitch", "s")):
        k, amplitude = spectra[name]
        line, = axis.plot(k, amplitude / ARCMIN_RAD, marker + "-", markersize=3, label=f"{name} (whole record)")
        colours[name] = line.get_color()
        if live_harmonics and name in live_harmonics:
            live = live_harmonics[name]
            axis.plot([int(x) for x in live], list(live.values()), marker, markersize=8, fillstyle="none",
                      label=f"{name}, monitor's last orbit (oblateness removed)")
    if record:
        for name, marker in (("roll", "*"), ("pitch", "P")):
            points = record.get(name) or {}
            if points:
                axis.plot([int(k) for k in points], list(points.values()), marker, color=colours[name], markersize=13,
                          markeredgecolor="black", linestyle="none", label=f"{name}, flight record (published)")
        axis.set_title(record["title"], fontsize=9)
    axis.axvspan(15, 25, color="orange", alpha=0.12, label="k = 15…25: horizon radiance zones")
    axis.set_xlabel("k = ω / Ω (harmonic of the orbital frequency)")
    axis.set_ylabel("amplitude, arcmin")
    axis.grid(True, alpha=0.3)
    axis.legend(fontsize=8)
    figure.suptitle("Harmonic amplitudes of the residual (physics.md §5.1)")
    figure.tight_layout()
    figure.savefig(paths[2], dpi=110)
    plt.close(figure)
    if tracker is not None:
        _plot_tracker(plt, out / "tracker.png", tracker)
    if pointing is not None:
        _plot_pointing(out / "pointing.png", pointing, orbit, summary["pointing"])
    return summary


def _plot_tracker(plt, path: Path, tracker: dict) -> None:
    """The ground track with the star tracker's frames without attitude by reason, and what each reason cost."""
    figure, axis = plt.subplots(figsize=(10, 5.2))
    latitude, longitude = tracker["track_deg"]
    wrapped = np.where(np.abs(np.diff(longitude)) > 180.0)[0] + 1  # no line across the date line
    for lat, lon in zip(np.split(latitude, wrapped), np.split(longitude, wrapped)):
        axis.plot(lon, lat, "-", color="0.75", linewidth=0.8)
    lost = tracker.get("truth_lost", {})
    reasons = np.asarray(tracker["reasons"])
    frame_latitude, frame_longitude = tracker["frames_deg"]
    for reason in sorted(set(reasons.tolist())):
        mine = reasons == reason
        cost = lost.get(reason)
        label = reason.replace("_", " ") + (f": {100.0 * cost['share']:.1f} % of the samples" if cost else "")
        axis.plot(np.asarray(frame_longitude)[mine], np.asarray(frame_latitude)[mine], ".", markersize=3, label=label)
    axis.set_xlim(-180, 180)
    axis.set_ylim(-90, 90)
    axis.set_xlabel("longitude, deg")
    axis.set_ylabel("geodetic latitude, deg")
    axis.grid(True, alpha=0.3)
    axis.legend(fontsize=8, loc="lower left", framealpha=0.9)
    axis.set_title("Star-tracker frames without attitude along the ground track (physics.md §6)", fontsize=10)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _plot_pointing(path: Path, pointing: np.ndarray, orbit, figures: dict) -> None:
    """``pointing.png``: the true roll and pitch against u, with −(oblateness model) when it is not compensated."""
    import matplotlib.pyplot as plt

    t, roll, pitch = pointing
    u_deg = np.degrees(np.mod(orbit.argument_of_latitude(t), 2.0 * math.pi))
    model_u = np.linspace(0.0, 2.0 * math.pi, 721)
    _, model_roll, model_pitch = closed_form_oblateness(model_u, orbit.altitude_m, orbit.inclination_rad)
    figure, axes = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    for axis, values, model, name in ((axes[0], roll, model_roll, "roll"), (axes[1], pitch, model_pitch, "pitch")):
        stats = figures[name]
        axis.plot(u_deg, values / ARCMIN_RAD, ".", markersize=1.5, alpha=0.5,
                  label=f"true {name} (σ {stats['sigma_arcmin']:.2f}′, mean {stats['mean_arcmin']:+.2f}′)")
        if not figures["oblateness_compensation"]:
            axis.plot(np.degrees(model_u), -model / ARCMIN_RAD, "k-", linewidth=1.5,
                      label="− oblateness model: where the loop settles (physics.md §2.1)")
        axis.set_ylabel(f"{name}, arcmin")
        axis.grid(True, alpha=0.3)
        axis.legend(loc="best", fontsize=8, framealpha=0.9)
    axes[1].set_xlabel("argument of latitude u, deg")
    axes[1].set_xlim(0, 360)
    figure.suptitle(f"True pointing error, PD loop at {figures['bandwidth_hz']:g} Hz "
                    f"(ζ = {figures['damping_ratio']:g}), "
                    f"oblateness compensation {'on' if figures['oblateness_compensation'] else 'off'}")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _json_default(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
