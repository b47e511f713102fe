"""The star tracker's frames, compiled: one loop over frames, the stages of physics.md §6 in order (numba).

:meth:`~pmv_ros.physics.star_tracker.model.StarTracker.measure` hands this
kernel what the frames see of the orbit (computed ahead in blocks, in numpy)
and the true attitude; :func:`measure_frames` runs, frame by frame:

1. where the frame looks: the tracker's axes in ECI and the inertial rate across and about the boresight;
2. the trail rate (``rate_too_high`` above the ceiling) and the smear it costs, ΔM_rate (item 3);
3. Sun, Moon and the Earth's limb: ``exclusion``, and the stray light just outside, ΔM_background (item 8);
4. the stars in the square field brighter than the detection limit (:mod:`.sky`'s cube-cell index);
5. proton hits, Poisson through the two windows, and the video buffer: ``buffer_overflow`` (items 6, 7);
6. the K brightest objects (stars with the ranking scatter, and the brightest hits) to recognition:
   ``no_stars``, ``recognition_failure`` (item 4);
7. the attitude from the catalogue stars used: the least-squares small rotation of their centroid errors (item 5).

Every draw is keyed by the frame's time and the star (:mod:`.draws`: the same
splitmix64 hash), so a frame is the same whatever frames are measured with
it. This is the only path: the node's one frame and a campaign's orbit of
frames; the stages the analysis tools look at alone — where a frame points
(:func:`pointing_batch`) and the stars in a field (:func:`field_stars_batch`)
— are the kernel's own functions.

Compiled on first use and cached beside this file (``cache=True``): the first
call of a fresh install compiles (design/star_tracker_kernel.py measures it),
later processes load the cache.
"""

from __future__ import annotations

import math

import numpy as np
from ..compiled import kernel

from ..constants import ARCSEC_RAD
from .draws import ndtri, poisson_quantile, uniform

#: d·ρ/f: the star spot's 90 %-energy diameter on the sky, 50 µm at 60 mm focal length (thesis l. 396–398) [D].
SPOT_RAD = 171.9 * ARCSEC_RAD
#: Lever arm of a rotation about the boresight: the RMS star distance from the centre of a 7.81° square [D].
ABOUT_BORESIGHT_LEVER = 0.055

# Outcome codes (model.Outcome), in the order a frame is checked for them after the override and the truth.
_OK, _RATE, _OUTAGE, _NO_STARS, _RECOGNITION, _OVERFLOW, _EXCLUSION, _INVALID = 0, 1, 2, 3, 4, 5, 6, 7


@kernel(error_model="python")
def slerp_frames(t0_s, q0, t1_s, q1, times_s):
    """The attitude at each frame time on the constant-rate turn between the truth samples around it, and the rate.

    Per frame n: the turn ω = rotation vector of q1 ⊗ q0⁻¹ over t1 − t0 (orbital components), and q(t) =
    exp(ω·(t − t0)) ⊗ q0 (the operations of :func:`pmv_ros.physics.attitude.slerp`). ``t0_s``, ``t1_s``,
    ``times_s`` ``(N,)``; ``q0``, ``q1`` ``(4, N)`` unit (x, y, z, w). Returns (attitudes ``(4, N)``, rates
    ``(3, N)`` rad/s).
    """
    n_frames = times_s.size
    attitude, rate = np.empty((4, n_frames)), np.empty((3, n_frames))
    for n in range(n_frames):
        ax, ay, az, aw = q1[0, n], q1[1, n], q1[2, n], q1[3, n]
        bx, by, bz, bw = -q0[0, n], -q0[1, n], -q0[2, n], q0[3, n]
        x = aw * bx + ax * bw + ay * bz - az * by
        y = aw * by - ax * bz + ay * bw + az * bx
        z = aw * bz + ax * by - ay * bx + az * bw
        w = aw * bw - ax * bx - ay * by - az * bz
        if w < 0.0:  # q and −q are the same rotation: the one with angle ≤ π
            x, y, z, w = -x, -y, -z, -w
        angle = 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), w)
        scale = 2.0 + angle ** 2 / 12.0 + 7.0 * angle ** 4 / 2880.0 if angle <= 1e-3 else angle / math.sin(0.5 * angle)
        dt = t1_s[n] - t0_s[n]
        rx, ry, rz = x * scale / dt, y * scale / dt, z * scale / dt
        rate[0, n], rate[1, n], rate[2, n] = rx, ry, rz
        elapsed = times_s[n] - t0_s[n]
        vx, vy, vz = elapsed * rx, elapsed * ry, elapsed * rz
        angle = math.sqrt(vx * vx + vy * vy + vz * vz)
        scale = 0.5 - angle ** 2 / 48.0 + angle ** 4 / 3840.0 if angle <= 1e-3 else math.sin(0.5 * angle) / angle
        ex, ey, ez, ew = vx * scale, vy * scale, vz * scale, math.cos(0.5 * angle)
        x, y, z, w = q0[0, n], q0[1, n], q0[2, n], q0[3, n]
        attitude[0, n] = ew * x + ex * w + ey * z - ez * y
        attitude[1, n] = ew * y - ex * z + ey * w + ez * x
        attitude[2, n] = ew * z + ex * y - ey * x + ez * w
        attitude[3, n] = ew * w - ex * x - ey * y - ez * z
    return attitude, rate


@kernel(error_model="python", inline="always")
def _cube_cell(x, y, z, cells):
    """The sky-index cell of a unit vector: the cube face it pierces and the square of the face (:mod:`.sky`)."""
    ax, ay, az = abs(x), abs(y), abs(z)
    if ax >= ay and ax >= az:
        axis, major, a, b = 0, x, y, z
    elif ay >= az:
        axis, major, a, b = 1, y, z, x
    else:
        axis, major, a, b = 2, z, x, y
    a, b = a / abs(major), b / abs(major)
    i = min(int((a + 1.0) * 0.5 * cells), cells - 1)
    j = min(int((b + 1.0) * 0.5 * cells), cells - 1)
    face = 2 * axis + (1 if major < 0.0 else 0)
    return (face * cells + i) * cells + j


@kernel(error_model="python")
def _look_at(q, n, tracker_axes, orbital_axes, m, relative_rate, frame_rate, in_orbital, axes):
    """Stage 1, frame ``n`` on the orbit's column ``m``: the tracker's axes in the orbital frame and in ECI
    (written into ``in_orbital``, ``axes``: columns the two focal-plane axes and the boresight) and its inertial
    rate in its own axes."""
    x, y, z, w = q[0, n], q[1, n], q[2, n], q[3, n]
    # The body's axes in the orbital frame (the columns of q's rotation matrix).
    b00, b01, b02 = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)
    b10, b11, b12 = 2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)
    b20, b21, b22 = 2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)
    for k in range(3):
        in_orbital[0, k] = b00 * tracker_axes[0, k] + b01 * tracker_axes[1, k] + b02 * tracker_axes[2, k]
        in_orbital[1, k] = b10 * tracker_axes[0, k] + b11 * tracker_axes[1, k] + b12 * tracker_axes[2, k]
        in_orbital[2, k] = b20 * tracker_axes[0, k] + b21 * tracker_axes[1, k] + b22 * tracker_axes[2, k]
    for i in range(3):
        for k in range(3):
            axes[i, k] = orbital_axes[i, 0, m] * in_orbital[0, k] + orbital_axes[i, 1, m] * in_orbital[1, k] \
                + orbital_axes[i, 2, m] * in_orbital[2, k]
    # Inertial rate: the rate relative to the orbital frame plus the frame's own turn about its Y.
    r0, r1, r2 = relative_rate[0, n], relative_rate[1, n] + frame_rate, relative_rate[2, n]
    return (in_orbital[0, 0] * r0 + in_orbital[1, 0] * r1 + in_orbital[2, 0] * r2,
            in_orbital[0, 1] * r0 + in_orbital[1, 1] * r1 + in_orbital[2, 1] * r2,
            in_orbital[0, 2] * r0 + in_orbital[1, 2] * r1 + in_orbital[2, 2] * r2)


@kernel(error_model="python")
def pointing_batch(q, tracker_axes, orbital_axes, relative_rate, frame_rate):
    """Stage 1 for every frame: the tracker's axes in ECI ``(3, 3, N)`` and the inertial rate across and about the
    boresight ``(N,)`` each."""
    n_frames = q.shape[1]
    axes_eci = np.empty((3, 3, n_frames))
    cross, about = np.empty(n_frames), np.empty(n_frames)
    in_orbital, axes = np.empty((3, 3)), np.empty((3, 3))
    for n in range(n_frames):
        t0, t1, t2 = _look_at(q, n, tracker_axes, orbital_axes, n, relative_rate, frame_rate[n], in_orbital, axes)
        axes_eci[:, :, n] = axes
        cross[n], about[n] = math.hypot(t0, t1), abs(t2)
    return axes_eci, cross, about


@kernel(error_model="python", inline="always")
def _in_field(star, axes, star_direction, limit_tan):
    """Whether a star is inside the square field of ``axes`` (columns: focal-plane axes, boresight), and its
    tangent-plane coordinates along the two focal-plane axes."""
    dx, dy, dz = star_direction[0, star], star_direction[1, star], star_direction[2, star]
    along = dx * axes[0, 2] + dy * axes[1, 2] + dz * axes[2, 2]
    u = (dx * axes[0, 0] + dy * axes[1, 0] + dz * axes[2, 0]) / along
    v = (dx * axes[0, 1] + dy * axes[1, 1] + dz * axes[2, 1]) / along
    return along > 0.0 and abs(u) <= limit_tan and abs(v) <= limit_tan, u, v


@kernel(error_model="python")
def field_stars_batch(axes_eci, half_width, n_sky, cell_start, cell_stars, cells_per_edge, star_direction):
    """Stage 4's field for every frame: (field index, star row, u rad, v rad) ``(S,)`` each, grouped by field,
    the stars in brightness order within each."""
    limit_tan = math.tan(half_width)
    n_frames = axes_eci.shape[2]
    found = 0
    field = np.empty(1024, np.int64)
    rows = np.empty(1024, np.int64)
    u_rad = np.empty(1024)
    v_rad = np.empty(1024)
    for n in range(n_frames):
        axes = axes_eci[:, :, n]
        cell = _cube_cell(axes[0, 2], axes[1, 2], axes[2, 2], cells_per_edge)
        for index in range(cell_start[cell], cell_start[cell + 1]):
            star = cell_stars[index]
            if star >= n_sky:
                continue
            inside, u, v = _in_field(star, axes, star_direction, limit_tan)
            if not inside:
                continue
            if found == field.size:
                field, rows = np.concatenate((field, field)), np.concatenate((rows, rows))
                u_rad, v_rad = np.concatenate((u_rad, u_rad)), np.concatenate((v_rad, v_rad))
            field[found], rows[found], u_rad[found], v_rad[found] = n, star, math.atan(u), math.atan(v)
            found += 1
    return field[:found], rows[:found], u_rad[:found], v_rad[:found]


@kernel(error_model="python")
def trail_rate(cross_rad_s, about_rad_s):
    """ω_eff = √(ω⊥² + (0.055·ω∥)²): the rate at which star images trail across the CCD, rad/s (§6 item 3)."""
    return math.hypot(cross_rad_s, ABOUT_BORESIGHT_LEVER * abs(about_rad_s))


@kernel(error_model="python")
def smear_loss_mag(trail_rate_rad_s, exposure_s):
    """ΔM_rate = 2.5·lg(max(1, ω·t_exp/(d·ρ/f))): what the trail costs the detection limit, mag (§6 item 3)."""
    return 2.5 * math.log10(max(1.0, trail_rate_rad_s * exposure_s / SPOT_RAD))


@kernel(error_model="python")
def recognition_failure(catalogue_stars, other_objects, p3, scale, p_conf):
    """p = 1 − (1 − p3·e^−(n−3)/n_s)·(1 − p_conf)^(others among the K) (physics.md §6 item 4)."""
    return 1.0 - (1.0 - p3 * math.exp(-(catalogue_stars - 3.0) / scale)) * (1.0 - p_conf) ** other_objects


#: What ``config`` of :func:`measure_frames` holds, in order.
CONFIG = ("exposure_s", "half_width_rad", "catalogue_stars", "sky_stars", "detection_limit_at_rest_mag",
          "max_objects", "rank_scatter_mag", "geometry_failure_3", "geometry_failure_scale", "false_object_failure",
          "centroid_error_rad", "bias_fraction", "max_rate_rad_s", "buffer_bytes", "bytes_per_pixel",
          "sun_exclusion_rad", "moon_exclusion_rad", "earth_limb_exclusion_rad", "stray_light_at_edge",
          "earth_radius_m", "side_hit_pixels_mean", "side_hit_pixels_variance", "lens_hit_pixels_mean",
          "lens_hit_pixels_variance", "hit_adc_low", "hit_adc_high", "star_adc_scale", "star_adc_hp", "star_pixels",
          "max_ranked_hits")


@kernel(error_model="python")
def measure_frames(frame_s, q_in, in_outage, rate_in, column, orbital_axes, frame_rate, position, sun, moon,
                   side_mean, lens_mean, tracker_axes, config, seeds,
                   star_direction, star_hp, star_hip, bias_u, bias_v, cell_start, cell_stars, cells_per_edge,
                   q_measured, outcome, stars_out, hits_out, used_out):
    """Measure frames ``(N,)``; the outputs are written into ``q_measured`` (4, N), ``outcome``, ``stars_out``,
    ``hits_out``, ``used_out`` (N,).

    ``frame_s`` (N,) the frames' times, s (each frame's draws are keyed by its time in whole nanoseconds,
    :func:`~pmv_ros.physics.star_tracker.draws.frame_key`); ``q_in`` (4, N) the true attitude (normalised here;
    not a finite quaternion near unit norm: INVALID_TRUTH),
    ``rate_in`` (3, N) the body rate relative to the orbital frame (a non-finite component counts as 0), rad/s;
    frame n sees the orbit of column ``column[n]`` of the orbit's arrays (orbital axes (3, 3, M), frame rate,
    position, Sun, Moon (3, M), mean hits through the side window and the lens (M,)).

    ``config`` (float64, :data:`CONFIG`): the model's parameters and constants, SI, in that order; ``seeds``
    ``(1,)`` uint64: the hashed seed (an array: numba's dispatch types a numpy scalar the slow way).
    """
    seed = seeds[0]
    exposure, half_width, n_catalogue, n_sky, limit0 = config[0], config[1], int(config[2]), int(config[3]), config[4]
    max_objects, rank_scatter, p3, n_scale, p_conf = int(config[5]), config[6], config[7], config[8], config[9]
    centroid, bias_fraction, max_rate, buffer_bytes, bytes_per_pixel = (config[10], config[11], config[12],
                                                                        config[13], config[14])
    sun_edge, moon_edge, limb_edge, stray_at_edge, earth_radius = config[15], config[16], config[17], config[18], \
        config[19]
    side_px, side_var, lens_px, lens_var = config[20], config[21], config[22], config[23]
    adc_low, adc_high, star_scale, star_hp_scale, star_px, max_hits = (
        math.log(config[24]), math.log(config[25]), config[26], config[27], config[28], int(config[29]))
    limit_tan = math.tan(half_width)
    fresh, kept = math.sqrt(1.0 - bias_fraction), math.sqrt(bias_fraction)
    in_orbital, axes = np.empty((3, 3)), np.empty((3, 3))
    q_true, relative_rate = np.empty((4, frame_s.size)), np.empty((3, frame_s.size))
    # Per frame, the objects that may go to recognition (stars, then hits), grown when a frame holds more.
    capacity = 256
    object_mag, object_catalogue, object_sent = np.empty(capacity), np.empty(capacity, np.bool_), \
        np.empty(capacity, np.bool_)
    object_star, object_u, object_v = np.empty(capacity, np.int64), np.empty(capacity), np.empty(capacity)
    for n in range(frame_s.size):
        key = np.int64(np.rint(frame_s[n] * 1e9))  # as draws.frame_key
        stars_out[n], hits_out[n], used_out[n] = 0, 0, 0
        for c in range(4):
            q_measured[c, n] = np.nan
        norm = math.sqrt(((q_in[0, n] * q_in[0, n] + q_in[1, n] * q_in[1, n]) + q_in[2, n] * q_in[2, n])
                         + q_in[3, n] * q_in[3, n])
        if not (math.isfinite(norm) and norm > 0.5):
            outcome[n] = _INVALID
            continue
        for c in range(4):
            q_true[c, n] = q_in[c, n] / norm
        for c in range(3):
            relative_rate[c, n] = rate_in[c, n] if math.isfinite(rate_in[c, n]) else 0.0
        m = column[n]
        # 1. Where it looks; 2. the trail and its smear.
        t0, t1, t2 = _look_at(q_true, n, tracker_axes, orbital_axes, m, relative_rate, frame_rate[m], in_orbital,
                              axes)
        trail = trail_rate(math.hypot(t0, t1), t2)
        smear_mag = smear_loss_mag(trail, exposure)
        # 3. Sun, Moon, the Earth's limb: their angles from the boresight, the exclusion and the stray light.
        bx, by, bz = axes[0, 2], axes[1, 2], axes[2, 2]
        excluded = False
        stray = 0.0
        for body in range(3):
            if body == 0:
                sx, sy, sz, edge = sun[0, m] - position[0, m], sun[1, m] - position[1, m], \
                    sun[2, m] - position[2, m], sun_edge
            elif body == 1:
                sx, sy, sz, edge = moon[0, m] - position[0, m], moon[1, m] - position[1, m], \
                    moon[2, m] - position[2, m], moon_edge
            else:
                sx, sy, sz, edge = -position[0, m], -position[1, m], -position[2, m], limb_edge
            distance = math.sqrt(sx * sx + sy * sy + sz * sz)
            angle = math.acos(min(max((sx * bx + sy * by + sz * bz) / distance, -1.0), 1.0))
            if body == 2:  # the limb: the centre's angle less the Earth's angular radius
                angle -= math.asin(min(earth_radius / distance, 1.0))
            if angle < edge:
                excluded = True
            if edge > 0.0 and edge <= angle < 2.0 * edge:  # (edge/θ)³ falling to nothing at twice the edge
                stray += (edge / max(angle, edge)) ** 3 - 0.125
        background_mag = 2.5 * math.log10(1.0 + stray_at_edge * (stray / 0.875))
        detection_limit = limit0 - smear_mag - background_mag
        # 4. The stars in the field brighter than the limit (candidates: the boresight's cell of the sky index),
        # each with its ranking scatter in this frame.
        cell = _cube_cell(bx, by, bz, cells_per_edge)
        registered = 0
        for index in range(cell_start[cell], cell_start[cell + 1]):
            star = cell_stars[index]
            if star >= n_sky or star_hp[star] > detection_limit:
                continue
            inside, u, v = _in_field(star, axes, star_direction, limit_tan)
            if not inside:
                continue
            if registered == capacity:
                object_mag, object_catalogue = np.concatenate((object_mag, object_mag)), \
                    np.concatenate((object_catalogue, object_catalogue))
                object_sent, object_star = np.concatenate((object_sent, object_sent)), \
                    np.concatenate((object_star, object_star))
                object_u, object_v = np.concatenate((object_u, object_u)), np.concatenate((object_v, object_v))
                capacity *= 2
            object_mag[registered] = star_hp[star] + rank_scatter * ndtri(uniform(seed, 0, key, star_hip[star], 2))
            object_catalogue[registered] = star < n_catalogue
            object_star[registered], object_u[registered], object_v[registered] = star, math.atan(u), math.atan(v)
            stars_out[n] += 1 if star < n_catalogue else 0
            registered += 1
        # 5. Proton hits through the side window and the lens, and the video buffer they fill with the stars.
        dice = uniform(seed, 5, key, 0, 1)
        side_hits = poisson_quantile(side_mean[m], uniform(seed, 6, key, 0, 1))
        lens_hits = poisson_quantile(lens_mean[m], uniform(seed, 7, key, 0, 1))
        footprint = ndtri(uniform(seed, 8, key, 0, 1))
        hits = side_hits + lens_hits
        hits_out[n] = hits
        hit_pixels = side_hits * side_px + lens_hits * lens_px \
            + math.sqrt(side_hits * side_var + lens_hits * lens_var) * footprint
        overflow = (star_px * registered + max(hit_pixels, 0.0)) * bytes_per_pixel > buffer_bytes
        # 6. The K brightest objects: the stars with their scatter and the brightest hits (order statistics of a
        # log-uniform brightness: the largest of m is V^(1/m), each next one the last times V^(1/(m − j))).
        ranked_hits = min(hits, max_hits)
        objects = registered + ranked_hits
        while objects > capacity:
            object_mag, object_catalogue = np.concatenate((object_mag, object_mag)), \
                np.concatenate((object_catalogue, object_catalogue))
            object_sent = np.concatenate((object_sent, object_sent))
            capacity *= 2
        fraction_log = 0.0
        for j in range(ranked_hits):
            fraction_log += math.log(uniform(seed, 9, key, j, 2)) / max(hits - j, 1.0)
            adc = math.exp(adc_low + math.exp(fraction_log) * (adc_high - adc_low))
            object_mag[registered + j] = star_hp_scale - 2.5 * math.log10(adc / star_scale)
            object_catalogue[registered + j] = False
        order = np.argsort(object_mag[:objects], kind="mergesort")  # stable: ties keep stars, then hits, in order
        object_sent[:objects] = False
        used = others = 0
        for rank in range(min(objects, max_objects)):
            index = order[rank]
            object_sent[index] = True
            if object_catalogue[index]:
                used += 1
            else:
                others += 1
        used_out[n] = used
        # The first reason that holds (model.REASON_ORDER).
        if in_outage[n]:
            outcome[n] = _OUTAGE
        elif trail > max_rate:
            outcome[n] = _RATE
        elif excluded:
            outcome[n] = _EXCLUSION
        elif overflow:
            outcome[n] = _OVERFLOW
        elif used < 3:
            outcome[n] = _NO_STARS
        elif dice < recognition_failure(used, others, p3, n_scale, p_conf):
            outcome[n] = _RECOGNITION
        else:
            outcome[n] = _OK
        if outcome[n] != _OK:
            continue
        # 7. The attitude from the catalogue stars used: each star's centroid error (half of its variance the
        # star's bias), fitted as a small rotation θ — a star at (u, v) moves by (−θy + θz·v, θx − θz·u).
        sigma = centroid * 10.0 ** (0.4 * smear_mag)
        count, su, sv, suu, e0, e1, e2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        for index in range(registered):
            if not (object_sent[index] and object_catalogue[index]):
                continue
            star = object_star[index]
            u, v = object_u[index], object_v[index]
            noise_u = ndtri(uniform(seed, 1, key, star_hip[star], 2))  # its centroid noise in this frame
            noise_v = ndtri(uniform(seed, 2, key, star_hip[star], 2))
            e_u = sigma * (fresh * noise_u + kept * bias_u[star])
            e_v = sigma * (fresh * noise_v + kept * bias_v[star])
            count += 1.0
            su += u
            sv += v
            suu += u * u + v * v
            e0 += e_v
            e1 -= e_u
            e2 += v * e_u - u * e_v
        theta0 = theta1 = theta2 = 0.0
        if centroid > 0.0:
            # The normal equations [[n, 0, −Σu], [0, n, −Σv], [−Σu, −Σv, Σ(u² + v²)]] θ = e, by elimination.
            theta2 = (e2 + (su * e0 + sv * e1) / count) / (suu - (su * su + sv * sv) / count)
            theta0 = (e0 + su * theta2) / count
            theta1 = (e1 + sv * theta2) / count
        # The error in the body frame, a rotation after the true attitude; the true quaternion's sign kept.
        vx = tracker_axes[0, 0] * theta0 + tracker_axes[0, 1] * theta1 + tracker_axes[0, 2] * theta2
        vy = tracker_axes[1, 0] * theta0 + tracker_axes[1, 1] * theta1 + tracker_axes[1, 2] * theta2
        vz = tracker_axes[2, 0] * theta0 + tracker_axes[2, 1] * theta1 + tracker_axes[2, 2] * theta2
        angle = math.sqrt(vx * vx + vy * vy + vz * vz)
        scale = 0.5 - angle ** 2 / 48.0 + angle ** 4 / 3840.0 if angle <= 1e-3 else math.sin(0.5 * angle) / angle
        ex, ey, ez, ew = vx * scale, vy * scale, vz * scale, math.cos(0.5 * angle)
        x, y, z, w = q_true[0, n], q_true[1, n], q_true[2, n], q_true[3, n]
        mx = w * ex + x * ew + y * ez - z * ey
        my = w * ey - x * ez + y * ew + z * ex
        mz = w * ez + x * ey - y * ex + z * ew
        mw = w * ew - x * ex - y * ey - z * ez
        sign = -1.0 if mx * x + my * y + mz * z + mw * w < 0.0 else 1.0
        q_measured[0, n], q_measured[1, n] = sign * mx, sign * my
        q_measured[2, n], q_measured[3, n] = sign * mz, sign * mw


@kernel(error_model="python")
def star_biases(seed, hip):
    """Each star's centroid bias, per focal-plane axis (the normals keyed by the star alone), ``(S,)`` each."""
    bias_u, bias_v = np.empty(hip.size), np.empty(hip.size)
    for i in range(hip.size):
        bias_u[i] = ndtri(uniform(seed, 3, 0, hip[i], 2))
        bias_v[i] = ndtri(uniform(seed, 4, 0, hip[i], 2))
    return bias_u, bias_v
