"""The instrument's per-sample pass: one compiled loop over samples, each doing only what its attitude changes.

For each sample, in the order of :mod:`pmv_ros.physics.instrument.sensor`'s stages:

1. the sensor's axes in ECI — the orbital frame of the sample's state (from the
   track, :mod:`.track`) times the body attitude and the mounting;
2. geometry — each chord's nadir angle grazing the ellipsoid and the top of the
   CO₂ layer (:func:`pmv_ros.physics.geometry.tangent_angles`);
3. the radiance each chord sees — at its horizon point (azimuth
   :func:`~pmv_ros.physics.instrument.horizon_fields.horizon_azimuth`) the
   climatology (a formula), the weather and the window-layer height (looked up on
   their grids, :func:`~pmv_ros.physics.instrument.horizon_fields.grid_value`);
4. detection — the signal chain (:func:`pmv_ros.physics.chain.sense_chord`) or the
   ideal detector;
5. validity — no horizon, no crossing, the Sun or the Moon near the chord's arc;
6. pair angles, the optional on-board oblateness compensation, and the lines of
   sight to the crossings.

A sample reads the same whatever other samples the call holds: the track and
the fields' nodes are fixed grids (:mod:`.track`, :mod:`.horizon_fields`), and
nothing else crosses from one sample to the next. A field node that is not
there yet stops the chain work of the call: :func:`sense_samples` returns the
missing nodes, the caller evaluates them and calls again.
"""

from __future__ import annotations

import math

import numpy as np

from ..chain import DISC_SAMPLE_INWARD_RAD, DetectionStatus, sense_chord, unpack
from ..chain.chord_geometry import ground_distance, height_rate_from_layer, sphere_horizon_nadir, sphere_slant_range
from ..compiled import kernel
from ..environment.climatology import climatology_ru
from ..environment.weather import radiance_level, uniform_height
from ..geometry import CHORD_AZIMUTHS_RAD, line_of_sight_x, line_of_sight_y, line_of_sight_z, roll_pitch, \
    tangent_angles
from ..orbit.two_body import orbit_angles, orbital_axes
from .bright_body import arc_distance, occulted
from .horizon_fields import grid_value, horizon_azimuth
from .oblateness import closed_form
from .track import track_weights

#: Layout of the configuration vector the kernel reads (:func:`sense_samples` ``config``).
(A_M, B_M, IDEAL_HEIGHT_M, CO2_TOP_M, SCAN_START_RAD, EXCLUSION_RAD, COMPENSATION, CHAIN, ENVIRONMENT, DISC_RU,
 WINDOW_M, CLIMATOLOGY, UNIFORM_RU, EPOCH_DAY, ETA, WINDOW_MEAN_M, WINDOW_HALF_RANGE_M, ALONG_SIGHT, MOUNTED,
 CO2_RADIANCE_RU, CO2_HEIGHT_M, EARTH_RADIUS_M) = range(22)
CONFIG_SIZE = 22
#: Length of the static vector: the configuration, the mounting (3 × 3), the two grids' parameters (4 each).
STATIC_SIZE = CONFIG_SIZE + 17

#: Columns of a sample's row of output (:func:`sense_samples` ``out``).
CORRECTED = slice(0, 4)  #: brightness-corrected crossing nadir angles, rad (NaN: invalid chord)
UNCORRECTED = slice(4, 8)  #: uncorrected crossing nadir angles, rad
ROLL, PITCH, ROLL_UNCORRECTED, PITCH_UNCORRECTED, ARGUMENT_OF_LATITUDE = 8, 9, 10, 11, 12
LINE_OF_SIGHT = slice(13, 25)  #: 4 × (x, y, z) unit lines of sight to the corrected crossings, sensor frame
STATUS = slice(25, 29)  #: ChordStatus codes
BLINDING = slice(29, 33)  #: body index (BODY_NAMES) blinding each chord, −1 none
POSITION = slice(33, 36)  #: ECI, m
VELOCITY = slice(36, 39)  #: ECI, m/s
HORIZON_RADIANCE = slice(39, 43)  #: B_m of each chord's profile, r.u. (NaN: no horizon, or the ideal detector)
WINDOW_HEIGHT = slice(43, 47)  #: h_w of each chord, m
DISC_SAMPLES = slice(47, 59)  #: 4 × 3 disc radiances along the line of sight, r.u. (NaN: the disc is uniform)
COLUMNS = 59

#: The chain's reason codes as the sensor's chord status (0 valid, 1 no horizon, 2 not detected).
_VALID, _NO_HORIZON, _NOT_DETECTED, _SUN_OR_MOON = 0, 1, 2, 3
_COS_AZIMUTH = np.cos(CHORD_AZIMUTHS_RAD)
_SIN_AZIMUTH = np.sin(CHORD_AZIMUTHS_RAD)
_INWARD = np.asarray(DISC_SAMPLE_INWARD_RAD)


@kernel
def _body_axes(x, y, z, w, mounting, mounted, r, out):
    """The sensor's axes in the orbital frame into ``out`` (3 × 3, columns): the rotation of the quaternion
    (x, y, z, w), normalised, then the mounting's (9 values, its 3 × 3 body → sensor row by row) when
    ``mounted``; ``r`` is scratch (3 × 3)."""
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    r[0, 0], r[0, 1], r[0, 2] = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)
    r[1, 0], r[1, 1], r[1, 2] = 2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)
    r[2, 0], r[2, 1], r[2, 2] = 2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)
    for i in range(3):
        for j in range(3):
            out[i, j] = (r[i, 0] * mounting[j] + r[i, 1] * mounting[3 + j] + r[i, 2] * mounting[6 + j]) if mounted \
                else r[i, j]


@kernel
def _chord_radiance(config, t_s, up, x_axis, y_axis, central_angle, radius, chord, grids, misses, count, samples):
    """Horizon radiance B_m (r.u.) and window-layer height h_w (m) of one chord, the disc samples into
    ``samples`` (line-of-sight climatology), and the misses' count (physics.md §3.2 item 3: the weather and
    the climatology a level at the horizon point, or the climatology along the line of sight)."""
    psi, horizontal = horizon_azimuth(chord, up, x_axis, y_axis)
    day = config[EPOCH_DAY] + t_s / 86400.0
    weather_params, weather_keys, weather_values = grids[0]
    height_params, height_keys, height_values = grids[1]
    anomaly = math.nan
    if weather_params[3] != 0.0:
        anomaly, count = grid_value(0, weather_params, weather_keys, weather_values, t_s, psi, misses, count)
    window = config[WINDOW_MEAN_M]
    if height_params[3] != 0.0:
        gaussian, count = grid_value(1, height_params, height_keys, height_values, t_s, psi, misses, count)
        window = uniform_height(gaussian, config[WINDOW_MEAN_M], config[WINDOW_HALF_RANGE_M])
    levels = (central_angle, central_angle, central_angle, central_angle)
    if config[ALONG_SIGHT] != 0.0:  # the ground the lines of sight at the inward sample angles hit
        altitude = radius - config[EARTH_RADIUS_M]
        phi0 = sphere_horizon_nadir(altitude, config[EARTH_RADIUS_M])
        slope = sphere_slant_range(altitude, config[EARTH_RADIUS_M])
        levels = (central_angle,
                  central_angle - ground_distance(phi0 - _INWARD[0], phi0, slope, config[EARTH_RADIUS_M])
                  / config[EARTH_RADIUS_M],
                  central_angle - ground_distance(phi0 - _INWARD[1], phi0, slope, config[EARTH_RADIUS_M])
                  / config[EARTH_RADIUS_M],
                  central_angle - ground_distance(phi0 - _INWARD[2], phi0, slope, config[EARTH_RADIUS_M])
                  / config[EARTH_RADIUS_M])
    points = 4 if config[ALONG_SIGHT] != 0.0 else 1
    level = math.nan
    for point in range(points):
        angle = levels[point]
        c, s = math.cos(angle), math.sin(angle)
        p = (c * up[0] + s * horizontal[0], c * up[1] + s * horizontal[1], c * up[2] + s * horizontal[2])
        if config[CLIMATOLOGY] != 0.0:
            mean = climatology_ru(math.atan2(p[2], math.hypot(p[0], p[1])), day)
        else:
            mean = config[UNIFORM_RU]
        value = radiance_level(mean, anomaly, config[ETA]) if weather_params[3] != 0.0 else mean
        if point == 0:
            level = value
        else:
            samples[point - 1] = value
    return level, window, count


def scratch_sizes(knots: int) -> tuple[int, int]:
    """Lengths of :func:`sense_samples`' float and int scratch arrays for a window ramp of ``knots`` knots."""
    terms = 2 * knots + 5
    return 3 * terms + 74, 2 * terms + 4


@kernel
def sense_samples(times, attitude, states, track_nodes, track_params, static, kit_vector, kit_tables, weather_keys,
                  weather_values, height_keys, height_values, out, misses, need, scratch, int_scratch):
    """Sense N samples: ``times`` (N,) s; ``attitude`` (N, 4): the quaternions orbital → body (x, y, z, w);
    ``states`` (N, 6), for a followed orbit, the position and velocity there (ECI, m, m/s); the track's node rows
    and (first node, spacing s, 1 if the orbit is followed) (:class:`~pmv_ros.physics.instrument.track.OrbitTrack`);
    ``static`` (:data:`STATIC_SIZE`): the configuration vector (layout above), the mounting (3 × 3, row by
    row), the two field grids' parameters; the chain's arrays (:class:`~pmv_ros.physics.chain.ChainArrays`);
    the field grids' node tables. Each sample's results go into its row of ``out`` (N, :data:`COLUMNS`);
    ``scratch`` and ``int_scratch`` hold the pass's working arrays (:func:`scratch_sizes`: a call of one
    sample allocates nothing).

    Every argument is an array: numba checks the arguments' types at each call, an array's in ≈ 0.1 µs,
    a tuple's in Python (≈ 5 µs for the chain's tables) — a sample's whole cost.

    Returns −1 when the track lacks nodes (the first and last it needs in ``need``), else the number of
    field nodes found missing (their rows in ``misses``: grid, time node, azimuth node); unless it is 0 the
    rows from the first sample that lacked one (``need[0]``) on are incomplete.
    """
    config, mounting = static[:CONFIG_SIZE], static[CONFIG_SIZE:CONFIG_SIZE + 9]
    grids = ((static[CONFIG_SIZE + 9:CONFIG_SIZE + 13], weather_keys, weather_values),
             (static[CONFIG_SIZE + 13:CONFIG_SIZE + 17], height_keys, height_values))
    kit = unpack(kit_vector, kit_tables)
    nodes = track_nodes
    first_node, spacing = int(track_params[0]), track_params[1]
    lowest, highest, covered = 2**62, -2**62, True
    for n in range(times.size):
        row, _ = track_weights(times[n], first_node, spacing)
        lowest, highest = min(lowest, row + first_node), max(highest, row + 3 + first_node)
        covered = covered and 0 <= row and row + 3 < nodes.shape[0]
    if not covered:  # all the samples' nodes, so that one cover holds them all
        need[0], need[1] = lowest, highest
        return -1
    followed = track_params[2] != 0.0
    terms = 2 * kit.ramp_heights.size + 5
    origins, coefficients, fraction = scratch[:terms], scratch[terms:2 * terms], scratch[2 * terms:3 * terms]
    o = 3 * terms
    samples, track_row, corrected, uncorrected, blinding = (scratch[o:o + 3], scratch[o + 3:o + 15],
                                                            scratch[o + 15:o + 19], scratch[o + 19:o + 23],
                                                            scratch[o + 23:o + 27])
    o += 27
    axes, rotation, body = (scratch[o:o + 9].reshape((3, 3)), scratch[o + 9:o + 18].reshape((3, 3)),
                            scratch[o + 18:o + 27].reshape((3, 3)))
    seen = scratch[o + 27:o + 47].reshape((4, 5))
    shapes, base, status = int_scratch[:terms], int_scratch[terms:2 * terms], int_scratch[2 * terms:2 * terms + 4]
    earth_radius = config[EARTH_RADIUS_M]
    ground = (config[A_M], config[A_M], config[B_M])
    co2_top = (config[A_M] + config[CO2_TOP_M], config[A_M] + config[CO2_TOP_M], config[B_M] + config[CO2_TOP_M])
    ideal = (config[A_M] + config[IDEAL_HEIGHT_M], config[A_M] + config[IDEAL_HEIGHT_M],
             config[B_M] + config[IDEAL_HEIGHT_M])
    scan_start = config[SCAN_START_RAD]
    count = 0
    first_missing = -1
    for n in range(times.size):
        t = times[n]
        row, w = track_weights(t, first_node, spacing)
        for column in range(0 if followed else 12):
            track_row[column] = (w[0] * nodes[row, column] + w[1] * nodes[row + 1, column]
                                 + w[2] * nodes[row + 2, column] + w[3] * nodes[row + 3, column])
        if followed:
            for column in range(6):
                track_row[column] = states[n, column]
            for column in range(6, 12):
                track_row[column] = (w[0] * nodes[row, column] + w[1] * nodes[row + 1, column]
                                     + w[2] * nodes[row + 2, column] + w[3] * nodes[row + 3, column])
        position = (track_row[0], track_row[1], track_row[2])
        velocity = (track_row[3], track_row[4], track_row[5])
        x_axis, y_axis, up = orbital_axes(position, velocity)
        _body_axes(attitude[n, 0], attitude[n, 1], attitude[n, 2], attitude[n, 3], mounting, config[MOUNTED] != 0.0,
                   rotation, body)
        for j in range(3):  # axes: columns the sensor's X, Y, Z in ECI
            for i in range(3):
                axes[i, j] = x_axis[i] * body[0, j] + y_axis[i] * body[1, j] + up[i] * body[2, j]
        sx = (axes[0, 0], axes[1, 0], axes[2, 0])
        sy = (axes[0, 1], axes[1, 1], axes[2, 1])
        sz = (axes[0, 2], axes[1, 2], axes[2, 2])
        horizon = tangent_angles(position, sx, sy, sz, ground)
        seen[:] = math.nan  # per chord: B_m, h_w, the three disc samples
        if config[CHAIN] == 0.0:  # the ideal detector: the geometric horizon of the emitting layer
            layer = tangent_angles(position, sx, sy, sz, ideal)
            for c in range(4):
                corrected[c] = uncorrected[c] = layer[c]
                status[c] = _VALID if math.isfinite(layer[c]) else _NO_HORIZON
        else:
            top = tangent_angles(position, sx, sy, sz, co2_top)
            radius = math.sqrt(position[0] ** 2 + position[1] ** 2 + position[2] ** 2)
            central_angle = math.acos(earth_radius / radius)
            for c in range(4):
                sign = 1.0 if c < 2 else -1.0
                column = sx if c % 2 == 0 else sy
                if not math.isfinite(horizon[c]):
                    corrected[c] = uncorrected[c] = math.nan
                    status[c] = _NO_HORIZON
                    continue
                slope = height_rate_from_layer(horizon[c], top[c], config[CO2_TOP_M], earth_radius)
                if config[ENVIRONMENT] != 0.0:
                    chord = (sign * column[0], sign * column[1], sign * column[2])
                    level, window, count = _chord_radiance(config, t, up, x_axis, y_axis, central_angle, radius,
                                                           chord, grids, misses, count, samples)
                else:
                    level, window = config[DISC_RU], config[WINDOW_M]
                if count:  # a field node is missing: look for the others only
                    if first_missing < 0:
                        first_missing = n
                    continue
                seen[c, 0], seen[c, 1] = level, window
                if config[ALONG_SIGHT] != 0.0 and config[ENVIRONMENT] != 0.0:
                    seen[c, 2], seen[c, 3], seen[c, 4] = samples[0], samples[1], samples[2]
                reading = sense_chord(horizon[c], slope, level, 0.0, 0.0, math.inf, earth_radius, window,
                                      config[CO2_RADIANCE_RU], config[CO2_HEIGHT_M], scan_start, samples,
                                      config[ALONG_SIGHT] != 0.0 and config[ENVIRONMENT] != 0.0, kit, origins,
                                      coefficients, shapes, base, fraction)
                corrected[c], uncorrected[c] = reading[4], reading[5]
                code = reading[6]
                status[c] = _VALID if code == DetectionStatus.OK else (
                    _NO_HORIZON if code == DetectionStatus.INVALID_INPUT
                    or code == DetectionStatus.SCAN_STARTED_IN_ATMOSPHERE else _NOT_DETECTED)
        if count:
            continue
        blinding[:] = -1.0
        if config[EXCLUSION_RAD] > 0.0:
            for body_index in range(2):
                first = 6 + 3 * body_index
                direction = (track_row[first] - position[0], track_row[first + 1] - position[1],
                             track_row[first + 2] - position[2])
                norm = math.sqrt(direction[0] ** 2 + direction[1] ** 2 + direction[2] ** 2)
                direction = (direction[0] / norm, direction[1] / norm, direction[2] / norm)
                if occulted(direction, position, earth_radius):
                    continue
                ds = (sx[0] * direction[0] + sx[1] * direction[1] + sx[2] * direction[2],
                      sy[0] * direction[0] + sy[1] * direction[1] + sy[2] * direction[2],
                      sz[0] * direction[0] + sz[1] * direction[1] + sz[2] * direction[2])
                for c in range(4):
                    if blinding[c] >= 0.0 or status[c] == _NO_HORIZON:
                        continue
                    ca, sa = _COS_AZIMUTH[c], _SIN_AZIMUTH[c]
                    distance = arc_distance(ca * ds[0] + sa * ds[1], -sa * ds[0] + ca * ds[1], -ds[2] + 0.0 * ca,
                                            min(horizon[c], scan_start), max(horizon[c], scan_start))
                    if distance <= config[EXCLUSION_RAD]:
                        blinding[c] = body_index
                        status[c] = _SUN_OR_MOON
        for c in range(4):
            if status[c] != _VALID:
                corrected[c] = uncorrected[c] = math.nan
        roll, pitch = roll_pitch(corrected[0], corrected[1], corrected[2], corrected[3])
        roll_raw, pitch_raw = roll_pitch(uncorrected[0], uncorrected[1], uncorrected[2], uncorrected[3])
        u, inclination, altitude = orbit_angles(position, velocity)
        if config[COMPENSATION] != 0.0:
            _, model_roll, model_pitch = closed_form(u, altitude, inclination, config[A_M], config[B_M],
                                                     earth_radius)
            roll, pitch = roll - model_roll, pitch - model_pitch
            roll_raw, pitch_raw = roll_raw - model_roll, pitch_raw - model_pitch
        row = out[n]
        for c in range(4):
            row[c], row[4 + c] = corrected[c], uncorrected[c]
            row[13 + 3 * c] = line_of_sight_x(corrected[c], CHORD_AZIMUTHS_RAD[c])
            row[14 + 3 * c] = line_of_sight_y(corrected[c], CHORD_AZIMUTHS_RAD[c])
            row[15 + 3 * c] = line_of_sight_z(corrected[c], CHORD_AZIMUTHS_RAD[c])
            row[25 + c], row[29 + c] = status[c], blinding[c]
        row[ROLL], row[PITCH], row[ROLL_UNCORRECTED], row[PITCH_UNCORRECTED] = roll, pitch, roll_raw, pitch_raw
        row[ARGUMENT_OF_LATITUDE] = u
        for i in range(3):
            row[33 + i], row[36 + i] = position[i], velocity[i]
        for c in range(4):
            row[39 + c], row[43 + c] = seen[c, 0], seen[c, 1]
            for i in range(3):
                row[47 + 3 * c + i] = seen[c, 2 + i]
    need[0] = first_missing
    return count
