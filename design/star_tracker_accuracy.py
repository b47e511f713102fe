"""The tracker's accuracy over an orbit: across and about the boresight, and how long its error holds.

physics.md §6 item 5.

    python design/star_tracker_accuracy.py [--preset config/kondor.yaml] [--orbits 1]

The preset's star tracker flies its orbit nadir pointing (true attitude =
the orbital frame), a frame a second. Printed: the per-frame ratio of the
about-boresight to the across-boresight error the field's geometry gives
(1/r_rms of the stars used; §6 expects a median ≈ 19, 5–95 % 16–25), the
RMS and median error across (per axis) and about the boresight of the OK
frames, and the residual's correlation time (the lag at which its
autocorrelation falls below 1/e; §6 item 5: half the variance is a bias
that holds while the same stars are in the field, which drifts one width in
≈ 123 s at 500 km).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from pmv_ros.physics.attitude import rotation_vector_from_quaternion  # noqa: E402
from pmv_ros.physics.constants import ARCSEC_RAD  # noqa: E402
from pmv_ros.physics.star_tracker import Outcome  # noqa: E402
from pmv_ros.runtime.flight import flight_values  # noqa: E402
from pmv_ros.runtime.tracker.runtime import TrackerRuntime  # noqa: E402
from pmv_ros.storage.files import read_yaml_file  # noqa: E402


def correlation_time_s(series: np.ndarray, step_s: float) -> float:
    """The first lag at which the autocorrelation of ``series`` (NaN: gaps) falls below 1/e, s."""
    x = series - np.nanmean(series)
    valid = np.isfinite(x)
    x = np.where(valid, x, 0.0)
    for lag in range(1, x.size // 2):
        both = valid[:-lag] & valid[lag:]
        r = np.sum(x[:-lag] * x[lag:] * both) / math.sqrt(np.sum(x[:-lag] ** 2 * both) * np.sum(x[lag:] ** 2 * both))
        if r < 1.0 / math.e:
            return lag * step_s
    return math.inf


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="config/kondor.yaml")
    parser.add_argument("--orbits", type=float, default=1.0)
    args = parser.parse_args(argv)
    values = flight_values(read_yaml_file(args.preset, "preset")).star_tracker
    runtime = TrackerRuntime(values, 0.0)
    tracker = runtime.tracker
    period = 2 * math.pi / tracker.orbit.mean_motion_rad_s
    step = values["frame_period_s"]
    t = np.arange(0.0, args.orbits * period, step)
    q = np.tile([[0.0], [0.0], [0.0], [1.0]], t.size)
    frames = tracker.measure(t, q, np.zeros((3, t.size)))
    # The geometry of each field: 1/r_rms of the catalogue stars sent to recognition (the K brightest at rest).
    pointing = tracker.pointing(q, np.zeros((3, t.size)), tracker.orbit_environment(t))
    stars = tracker.sky.stars_in_fields(pointing.axes_eci, tracker.parameters.field_width_rad / 2.0,
                                        tracker.parameters.catalogue_stars)
    ratio = np.full(t.size, np.nan)
    for k in range(t.size):
        mine = stars.field == k
        order = np.argsort(stars.hp_mag[mine])[:10]
        u, v = stars.u_rad[mine][order], stars.v_rad[mine][order]
        if u.size >= 3:
            ratio[k] = 1.0 / math.sqrt(np.mean((u - u.mean()) ** 2 + (v - v.mean()) ** 2))
    ok = frames.outcome == Outcome.OK
    error = np.full((3, t.size), np.nan)
    error[:, ok] = rotation_vector_from_quaternion(frames.q_measured[:, ok]) / ARCSEC_RAD  # tracker axes = body
    across = error[:2]
    print(f"{args.preset}: {t.size} frames over {args.orbits:g} orbit(s), {ok.mean() * 100:.1f} % with attitude")
    print(f"  field geometry: about/across ratio 1/r_rms median {np.nanmedian(ratio):.1f} "
          f"(5–95 %: {np.nanpercentile(ratio, 5):.1f}–"
          f"{np.nanpercentile(ratio, 95):.1f})")
    print(f"  error across the boresight: RMS {np.sqrt(np.nanmean(across ** 2)):.2f}″ per axis, median |.| "
          f"{np.nanmedian(np.abs(across)) / 0.6745:.2f}″ (as a σ); "
          f"about it: RMS {np.sqrt(np.nanmean(error[2] ** 2)):.1f}″, "
          f"median-based σ {np.nanmedian(np.abs(error[2])) / 0.6745:.1f}″; RMS ratio about/across "
          f"{np.sqrt(np.nanmean(error[2] ** 2) / np.nanmean(across ** 2)):.1f}")
    print(f"  correlation time (autocorrelation < 1/e): across {correlation_time_s(error[0], step):.0f} s, "
          f"{correlation_time_s(error[1], step):.0f} s; about {correlation_time_s(error[2], step):.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
