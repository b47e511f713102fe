"""Write a two-line element set whose SGP4 orbit matches a circular preset's (config/meteor_m2_tle.yaml).

    python tools/make_tle.py config/meteor_m2.yaml

The element set has the preset's epoch (``sim.epoch_utc``) and inclination,
eccentricity 0, no drag, and three elements fitted with SGP4 so that the
orbit flown from it matches the preset's circular one:

* the mean motion: the mean of |r| − 6371 km over one day equals the preset's
  ``orbit.altitude_km`` (SGP4's short-period J2 terms make the osculating
  radius swing by a few km about it);
* the right ascension of the node and the mean anomaly: at the epoch the
  osculating node (in the mean-of-date ECI frame) and argument of latitude
  equal the preset's ``orbit.raan_deg`` and ``orbit.u0_deg``.

Prints the two lines and the figures reached (the element set's format
rounds angles to 1e-4° and the mean motion to 1e-8 rev/day).
"""

from __future__ import annotations

import argparse
import math
import sys
from datetime import datetime, timezone

import numpy as np
import yaml

from pmv_ros.physics.constants import EARTH_MEAN_RADIUS_M, GM_EARTH_M3_S2
from pmv_ros.physics.orbit.ephemeris import Epoch
from pmv_ros.physics.orbit.tle import TleOrbit, make_element_set


def preset_orbit(path: str) -> dict:
    """The circular orbit and epoch of a preset: altitude km, inclination, node, u0 (deg) and the epoch."""
    document = yaml.safe_load(open(path))
    merged = {}
    for section in ("/**", "sensor_node"):
        parameters = (document.get(section) or {}).get("ros__parameters", {})
        for key, value in (parameters.get("orbit") or {}).items():
            merged[key] = value
        if "sim" in parameters:
            merged["epoch_utc"] = parameters["sim"].get("epoch_utc", merged.get("epoch_utc"))
    return {"altitude_km": float(merged["altitude_km"]), "inclination_deg": float(merged["inclination_deg"]),
            "raan_deg": float(merged.get("raan_deg", 0.0)), "u0_deg": float(merged.get("u0_deg", 0.0)),
            "epoch_utc": merged["epoch_utc"]}


def fly(lines, epoch: Epoch):
    """Mean altitude over one day (km), and the osculating node and u at the epoch (deg)."""
    orbit = TleOrbit(*lines, epoch, 0.0)
    t = np.arange(0.0, 86400.0, 10.0)
    position, _ = orbit.state_eci(t)
    mean_altitude = float(np.mean(np.linalg.norm(position, axis=0)) - EARTH_MEAN_RADIUS_M) / 1e3
    return mean_altitude, math.degrees(orbit.raan_rad), math.degrees(orbit.arg_latitude_at_epoch_rad), orbit


def wrap180(angle_deg: float) -> float:
    return (angle_deg + 180.0) % 360.0 - 180.0


def fit(target: dict):
    """Mean motion, node and mean anomaly fitted by fixed-point steps (each converges by a factor ≥ 100)."""
    epoch = Epoch.from_utc(target["epoch_utc"])
    moment = datetime.fromisoformat(target["epoch_utc"].replace("Z", "+00:00")).astimezone(timezone.utc)
    radius = EARTH_MEAN_RADIUS_M + target["altitude_km"] * 1e3
    mean_motion = math.sqrt(GM_EARTH_M3_S2 / radius**3) * 86400.0 / (2.0 * math.pi)  # rev/day, a first guess
    raan, anomaly = target["raan_deg"], target["u0_deg"]
    for _ in range(8):
        lines = make_element_set(moment, target["inclination_deg"], raan, 0.0, 0.0, anomaly, mean_motion)
        altitude, node, u0, _ = fly(lines, epoch)
        # Kepler's third law: n ∝ a^(−3/2), so a radius too high by δ wants n larger by 1.5 δ / a.
        mean_motion *= 1.0 + 1.5 * (altitude - target["altitude_km"]) * 1e3 / radius
        raan -= wrap180(node - target["raan_deg"])
        anomaly -= wrap180(u0 - target["u0_deg"])
    lines = make_element_set(moment, target["inclination_deg"], raan, 0.0, 0.0, anomaly, mean_motion)
    return lines, fly(lines, epoch)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("preset", help="a circular-orbit preset, e.g. config/meteor_m2.yaml")
    args = parser.parse_args(argv)
    target = preset_orbit(args.preset)
    lines, (altitude, node, u0, orbit) = fit(target)
    t = np.arange(0.0, 86400.0, 10.0)
    radius_km = np.linalg.norm(orbit.state_eci(t)[0], axis=0) / 1e3 - EARTH_MEAN_RADIUS_M / 1e3
    inclination = np.degrees(orbit.orbit_angles(t)[1])
    print(lines[0])
    print(lines[1])
    print(f"# target: H = {target['altitude_km']:g} km, i = {target['inclination_deg']:g}°, node "
          f"{target['raan_deg']:g}°, u0 {target['u0_deg']:g}° at {target['epoch_utc']}", file=sys.stderr)
    print(f"# reached: one-day mean altitude {altitude:.4f} km (osculating {radius_km.min():.2f} … "
          f"{radius_km.max():.2f} km), osculating node {node:.5f}°, u0 {u0:.5f}°, osculating inclination "
          f"{inclination.min():.4f} … {inclination.max():.4f}°, nodal period {orbit.period_s:.2f} s",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
