"""How far the shipped radiation grid's interpolation is from aep8 itself, at random points (physics.md §6 item 6).

Run with ``aep8`` installed (a development tool, not a run-time dependency):

    python design/star_tracker_grid_error.py [--points 1000] [--seed 1] [--max-altitude-km 2000]

Points uniform over the sphere, altitude uniform between 150 km and
``--max-altitude-km``. For each AP8 column (MIN/MAX, > 45/100 MeV) it prints
the largest and the 99th-percentile relative error where aep8's flux is
non-negligible (≥ 10 cm⁻² s⁻¹: below that a 0.75 s frame sees < 1 hit in 10),
the largest absolute error elsewhere, and the error of L where L ≤ 20.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tools"))
from make_radiation_grid import aep8_environment  # noqa: E402
from pmv_ros.physics.star_tracker.radiation import FLUX_COLUMNS, RadiationGrid  # noqa: E402

#: Fluxes below which the error is not reported as relative, cm⁻² s⁻¹: 10 (a 0.75 s frame sees ≈ 1 hit through the
#: side window at 12) and 100 (≈ 8 hits, where frames with ≥ 5 hits are decided).
THRESHOLDS = (10.0, 100.0)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--max-altitude-km", type=float, default=2000.0)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    latitude = np.degrees(np.arcsin(rng.uniform(-1.0, 1.0, args.points)))
    longitude = rng.uniform(-180.0, 180.0, args.points)
    altitude = rng.uniform(150.0, args.max_altitude_km, args.points)
    truth = aep8_environment(latitude, longitude, altitude)
    grid = RadiationGrid()
    print(f"{args.points} points, altitude 150 … {args.max_altitude_km:g} km, seed {args.seed}")
    for (solar, energy), name in FLUX_COLUMNS.items():
        flux45, flux100, _ = grid.environment(np.radians(latitude), np.radians(longitude), altitude * 1e3, solar)
        ours = flux45 if energy == 45 else flux100
        real = truth[name]
        for threshold in THRESHOLDS:
            big = real >= threshold
            if not big.any():
                continue
            relative = np.abs(ours[big] - real[big]) / real[big]
            worst = int(np.flatnonzero(big)[np.argmax(relative)])
            print(f"  AP8{solar.upper()} >{energy} MeV, {big.sum()} points ≥ {threshold:g} cm-2 s-1: relative error "
                  f"largest {relative.max():.3f} (at {latitude[worst]:.1f}°, {longitude[worst]:.1f}°, "
                  f"{altitude[worst]:.0f} km: aep8 {real[worst]:.1f}, grid {ours[worst]:.1f}), 99th pct "
                  f"{np.percentile(relative, 99):.3f}, median {np.median(relative):.4f}; below, largest |error| "
                  f"{np.abs(ours[~big] - real[~big]).max():.2f} cm-2 s-1")
    _, _, shell = grid.environment(np.radians(latitude), np.radians(longitude), altitude * 1e3)
    real_l = np.where(truth["inverse_l"] > 0, 1.0 / np.where(truth["inverse_l"] > 0, truth["inverse_l"], 1.0), np.inf)
    finite = real_l <= 20.0
    print(f"  McIlwain L (≤ 20, {finite.sum()} points): relative error largest "
          f"{np.max(np.abs(shell[finite] - real_l[finite]) / real_l[finite]):.4f}; "
          f"L ≥ 7.1 misjudged at {np.sum((shell >= 7.1) != (real_l >= 7.1))} points")
    return 0


if __name__ == "__main__":
    sys.exit(main())
