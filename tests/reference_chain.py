"""Reference transcription of the published simulation program (physics.md §3–§4) — the test oracle.

Plain step-by-step loops in pure Python, written to be read against the
text, not to be fast: the horizon profile of §3 evaluated point by point
from the exact chord geometry, the IFOV energy of each step as a numerical
integral over the field, the Duhamel sum of §4 step 3 *as written*
(O(steps²)), the comparators with linear interpolation, Gam/Del, the table
look-up. It shares no code with the fast chain (pmv_ros.physics.chain) beyond
the parameter record, so agreement between the two is evidence.

Two liberties, neither of which changes a result:

* the scan stops once both comparators have fired (the output at a step
  depends only on earlier steps, so the rest of the 2000 steps could not
  change t(1) or t(2));
* the field integral is split at the profile's break points (space/CO₂,
  the ramp knots, the limb, a jump) and each piece integrated by
  Gauss–Legendre in the angle α of a = γ·sin α, which turns the disc's
  √(γ² − a²) sensitivity into the smooth (2/π)·cos²α — accurate to
  better than 1e-6 of the energy, where a plain sum over sample points
  would need tens of thousands of points to place an edge to 0.01′.
"""

from __future__ import annotations

import math

import numpy as np

#: Gauss–Legendre nodes and weights on [−1, 1] for each smooth piece of the field.
_NODES, _WEIGHTS = (list(map(float, a)) for a in np.polynomial.legendre.leggauss(12))


def _profile(theta, chord):
    """Radiance, r.u., of the line of sight at nadir angle ``theta`` (physics.md §3), plain arithmetic."""
    r, s = chord["earth_radius_m"], chord["tangent_height_rate_m"]
    rho = math.hypot(r, s)
    offset = chord["horizon_nadir_rad"] - math.atan2(r, s)
    height = rho * math.sin(theta - offset) - r
    b_m, b_a = chord["disc_radiance_ru"], chord["co2_radiance_ru"]
    h_w = chord["window_height_m"]
    if height > 0.0:
        if height > max(chord["co2_top_height_m"], h_w):
            return 0.0                      # space
        if height > h_w:
            return b_a                      # the CO₂ layer
        u = height / h_w                    # the window ramp, S piecewise linear in u
        knots_u, knots_s = chord["ramp_heights"], chord["ramp_values"]
        for k in range(len(knots_u) - 1):
            if knots_u[k] <= u <= knots_u[k + 1]:
                w = (u - knots_u[k]) / (knots_u[k + 1] - knots_u[k])
                shape = knots_s[k] + w * (knots_s[k + 1] - knots_s[k])
                return b_a + (b_m - b_a) * shape
        return b_a
    # The disc: where does the line of sight hit? x inside the limb, central angle from the horizon point.
    x = max(0.0, chord["horizon_nadir_rad"] - theta)  # ≥ 0 up to round-off where the height is ≤ 0
    kappa = s / r
    central = 2.0 * math.asin(min(1.0, math.sqrt(math.sin(0.5 * x) ** 2 + 0.5 * kappa * math.sin(x)))) - x
    distance = r * central
    radiance = b_m + chord["gradient_ru_per_m"] * distance
    if distance >= chord["jump_distance_m"]:
        radiance += chord["jump_ru"]
    return radiance


def _break_points(chord):
    """Nadir angles where the profile has a kink or a jump."""
    r, s = chord["earth_radius_m"], chord["tangent_height_rate_m"]
    rho = math.hypot(r, s)
    offset = chord["horizon_nadir_rad"] - math.atan2(r, s)

    def nadir_of_height(h):
        return math.asin((r + h) / rho) + offset

    points = [nadir_of_height(max(chord["co2_top_height_m"], chord["window_height_m"]))]
    points += [nadir_of_height(u * chord["window_height_m"]) for u in chord["ramp_heights"]]
    points.append(chord["horizon_nadir_rad"])
    if chord["jump_ru"] != 0.0 and math.isfinite(chord["jump_distance_m"]):
        central = math.atan2(s, r) - chord["jump_distance_m"] / r
        points.append(math.atan2(r * math.sin(central), rho - r * math.cos(central)) + offset)
    return points


def _field_energy(theta, chord, gamma, breaks):
    """U: the field's energy with its centre at nadir ``theta`` (physics.md §4, step 2)."""
    # Field point at offset a = γ sin α inwards of the centre: nadir θ − a, sensitivity (2/π) cos²α dα.
    cuts = [-0.5 * math.pi, 0.5 * math.pi]
    for b in breaks:
        a = theta - b
        if -gamma < a < gamma:
            cuts.append(math.asin(a / gamma))
    cuts.sort()
    energy = 0.0
    for lo, hi in zip(cuts[:-1], cuts[1:]):
        half, mid = 0.5 * (hi - lo), 0.5 * (hi + lo)
        for node, weight in zip(_NODES, _WEIGHTS):
            alpha = mid + half * node
            sensitivity = (2.0 / math.pi) * math.cos(alpha) ** 2
            energy += weight * half * sensitivity * _profile(theta - gamma * math.sin(alpha), chord)
    return energy


def _interpolate_table(table_del, table_pop, value):
    """POP = F(Del) by linear interpolation in the stored table, clamped at its ends (physics.md §4, step 6)."""
    if value <= table_del[0]:
        return table_pop[0]
    if value >= table_del[-1]:
        return table_pop[-1]
    for k in range(len(table_del) - 1):
        if table_del[k] <= value <= table_del[k + 1]:
            w = (value - table_del[k]) / (table_del[k + 1] - table_del[k])
            return table_pop[k] + w * (table_pop[k + 1] - table_pop[k])
    return math.nan


def reference_chord(horizon_nadir_rad, tangent_height_rate_m, disc_radiance_ru, params, *, scan_start_nadir_rad=None,
                    gradient_ru_per_m=0.0, jump_ru=0.0, jump_distance_m=math.inf, window_height_m=None,
                    co2_radiance_ru=None, co2_top_height_m=None, earth_radius_m=6371000.0, table=None):
    """One chord through the published program; returns a dict of Gam, Del, POP, Gam′ (rad) and t(1), t(2) (s).

    Arguments as :func:`pmv_ros.physics.chain.sense_horizon_chords`, scalars
    only; ``table`` is None or a pair (del_rad list, pop_rad list).
    """
    chord = {
        "horizon_nadir_rad": float(horizon_nadir_rad), "tangent_height_rate_m": float(tangent_height_rate_m),
        "disc_radiance_ru": float(disc_radiance_ru), "gradient_ru_per_m": float(gradient_ru_per_m),
        "jump_ru": float(jump_ru), "jump_distance_m": float(jump_distance_m),
        "window_height_m": float(params.window_height_m if window_height_m is None else window_height_m),
        "co2_radiance_ru": float(params.co2_radiance_ru if co2_radiance_ru is None else co2_radiance_ru),
        "co2_top_height_m": float(params.co2_top_height_m if co2_top_height_m is None else co2_top_height_m),
        "earth_radius_m": float(earth_radius_m),
        "ramp_heights": list(params.ramp.heights), "ramp_values": list(params.ramp.values),
    }
    gamma = 0.5 * params.ifov_full_angle_rad
    scan_rate, dt, tau = params.scan_rate_rad_s, params.time_step_s, params.detector_time_constant_s
    breaks = _break_points(chord)
    theta0 = breaks[0] + gamma if scan_start_nadir_rad is None else float(scan_start_nadir_rad)
    thresholds = [params.threshold_1_ru, params.threshold_2_ru]
    crossing_times = [math.nan, math.nan]

    times, energies, outputs = [], [], []
    for v in range(params.max_steps):
        # Step 1: the IFOV centre.
        t_v = v * dt
        theta_v = theta0 - scan_rate * t_v
        # Step 2: the energy from the whole field.
        times.append(t_v)
        energies.append(_field_energy(theta_v, chord, gamma, breaks))
        # Step 3: the Duhamel sum, as written.
        out = 0.0
        for j in range(v + 1):
            d_u = energies[j] - (energies[j - 1] if j > 0 else 0.0)
            out += d_u * (1.0 - math.exp(-(t_v - times[j]) / tau))
        outputs.append(out)
        # Step 4: the comparators, linear interpolation between steps.
        for k, threshold in enumerate(thresholds):
            if math.isnan(crossing_times[k]) and out > threshold and v > 0:
                previous = outputs[v - 1]
                crossing_times[k] = times[v - 1] + dt * (threshold - previous) / (out - previous)
        if not math.isnan(crossing_times[0]) and not math.isnan(crossing_times[1]):
            break

    # Step 5: Gam and Del.
    gam = crossing_times[0] * scan_rate
    delta = (crossing_times[1] - crossing_times[0]) * scan_rate
    # Step 6: the brightness correction.
    pop = 0.0 if table is None else _interpolate_table(list(table[0]), list(table[1]), delta)
    return {"gam_rad": gam, "del_rad": delta, "pop_rad": pop, "gam_corrected_rad": gam - pop,
            "t1_s": crossing_times[0], "t2_s": crossing_times[1], "scan_start_nadir_rad": theta0,
            "steps": len(outputs)}


def reference_pair_angle(gam_1_rad, gam_2_rad):
    """β = ½(Gam(1) − Gam(2)) (physics.md §4, step 7)."""
    return 0.5 * (gam_1_rad - gam_2_rad)
