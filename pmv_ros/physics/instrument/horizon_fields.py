"""The environment's random fields along the horizon, on a fixed (time, azimuth) grid the sensor fills as it goes.

A chord's horizon point lies on the horizon circle around the sub-satellite
point — at the central angle acos(R/r) from it, in the direction the chord
points when made horizontal — so where it is at time t depends on the
attitude only through one angle: its azimuth ψ from the orbital X axis
(:func:`horizon_azimuth`). The weather and the window-layer height at the
horizon are therefore functions f(t, ψ) of the track alone, and
:class:`FieldGrid` keeps each on a grid fixed on the fields' clock and around
the circle:

* time nodes t_k with origin + t_k = k·Δt (the fields' clock: UTC for the flight
  environment, so a real-time and a fast-time run have the same nodes),
  Δt a fraction (:data:`FIELD_TIME_FRACTION`) of the time a horizon point takes
  to cross the field's shortest scale;
* azimuth nodes ψ_j = 2πj/M, M a multiple of 4 so that the chords of a
  sensor at zero yaw sit on nodes, spaced a fraction
  (:data:`FIELD_AZIMUTH_FRACTION`) of that scale along the circle.

A sample's value is the cubic through the four time nodes around it (Lagrange's
form), at its azimuth the line between the two azimuth nodes around it (the
node itself when the azimuth sits on it, :data:`ON_NODE`) — local, so the
value at a time and place is the same whatever block of samples asked. Nodes
are evaluated when a sample first needs them (:meth:`HorizonFields.fill`,
numpy over all the missing nodes of a call at once) and kept for the
samples after, in a hash table by (time node, azimuth node) (:class:`NodeTable`).

The node's horizon circle comes from the orbit at the node's time
(:meth:`~pmv_ros.physics.instrument.track.OrbitTrack.node_states`); for an
orbit followed from odometry, a node placed from an extrapolated state is
placed again after new odometry arrives (:meth:`HorizonFields.refresh`).

The climatology is not gridded: it is a formula in latitude and day, and the
sensor's kernel evaluates it at each horizon point itself.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import kernel
from ..constants import EARTH_MEAN_RADIUS_M
from ..orbit.two_body import eci_to_ecef, geocentric_latitude_longitude, orbital_frame_from_state
from .track import lagrange_weights

#: Time-node spacing as a fraction of the time a horizon point takes to cross a field's shortest scale.
#: A cubic through nodes this close reproduces a wave of that scale to ≈ (2π·0.1)⁴·9/384 ≈ 0.4 % of its
#: amplitude (the middle of the four-node span), and longer waves better (design/field_grid_accuracy.py).
FIELD_TIME_FRACTION = 0.1
#: Azimuth-node spacing along the horizon circle as a fraction of a field's shortest scale. A chord between two
#: nodes (a sensor with a yaw, or roll and pitch both off zero) takes the line between them: ≈ (2π·0.025)²/8
#: ≈ 0.3 % of a wave of that scale at worst, as the time cubic; two nodes, not the cubic's four, because every
#: node a chord needs at each time node costs an evaluation of the fields (design/field_grid_accuracy.py).
FIELD_AZIMUTH_FRACTION = 0.025
#: Longest time-node spacing, s.
MAX_FIELD_GRID_S = 30.0
#: Ground speed of a horizon point along its track, m/s (the orbital rate on the Earth's surface,
#: ≈ 6.6 km/s at 500–835 km, plus up to 0.46 km/s of Earth rotation), rounded up.
HORIZON_POINT_SPEED_M_S = 7.2e3
#: An azimuth within this fraction of a node's cell from the node is on it (one node, no azimuth cubic):
#: a chord at zero yaw, whose azimuth is the node's to rounding.
ON_NODE = 1e-9
#: Time nodes filled ahead of a missing one, at the same azimuth nodes: the attitude changes slowly against the
#: nodes' spacing, so the next samples need them, and one evaluation of many nodes costs less than many of one
#: (a fill's own cost is ≈ 0.3 ms). A followed orbit's nodes ahead are placed from its newest states carried
#: forward (:meth:`~pmv_ros.physics.instrument.track.OrbitTrack.node_states`): two, not further.
NODES_AHEAD = 64
NODES_AHEAD_FOLLOWED = 2
#: Misses a sample compares a missing node with before it records it (a sample's nodes: 4 chords × 4 time nodes ×
#: 2 azimuth nodes × 2 fields, mostly the sample before's).
RECENT_MISSES = 64
#: Time nodes whose horizon circles a grid keeps before it drops those behind the samples.
RINGS_KEPT = 4096
#: Key of an empty place in a :class:`NodeTable`.
EMPTY = np.iinfo(np.int64).min
#: Layout of :attr:`FieldGrid.params`.
_SPACING, _ORIGIN, _AZIMUTHS, _ENABLED = range(4)


@kernel
def _slot(keys, key):
    """Where ``key`` is, or the empty place where it would go, in the open-addressing table ``keys``."""
    mask = keys.size - 1
    place = ((key * -7046029254386353131) >> 17) & mask  # Fibonacci hashing (the multiplier wraps)
    while keys[place] != key and keys[place] != EMPTY:
        place = (place + 1) & mask
    return place


@kernel
def _absent(keys, candidates):
    """Which of ``candidates`` the table ``keys`` does not hold."""
    out = np.empty(candidates.size, np.bool_)
    for n in range(candidates.size):
        out[n] = keys[_slot(keys, candidates[n])] == EMPTY
    return out


@kernel
def _insert(keys, values, new_keys, new_values):
    """Put ``new_keys`` → ``new_values`` into the table (it has room); returns how many were new."""
    added = 0
    for n in range(new_keys.size):
        place = _slot(keys, new_keys[n])
        if keys[place] == EMPTY:
            added += 1
        keys[place] = new_keys[n]
        values[place] = new_values[n]
    return added


class NodeTable:
    """A field's node values by key (time node × azimuths + azimuth node): an open-addressing hash table the
    kernel reads (:func:`grid_value`) and :class:`HorizonFields` fills; at most half full."""

    def __init__(self, capacity: int = 1024):
        self.keys = np.full(capacity, EMPTY, np.int64)
        self.values = np.full(capacity, np.nan)
        self.count = 0

    def insert(self, keys: np.ndarray, values: np.ndarray, keep=None) -> None:
        """Add ``keys`` → ``values``; when it would be more than half full it is rebuilt, keeping only the
        entries ``keep(keys)`` says (all when None), and grown if still needed."""
        if 2 * (self.count + keys.size) > self.keys.size:
            live = self.keys != EMPTY
            old_keys, old_values = self.keys[live], self.values[live]
            if keep is not None:
                kept = keep(old_keys)
                old_keys, old_values = old_keys[kept], old_values[kept]
            capacity = self.keys.size
            while 2 * (old_keys.size + keys.size) > capacity:
                capacity *= 2
            self.keys = np.full(capacity, EMPTY, np.int64)
            self.values = np.full(capacity, np.nan)
            self.count = _insert(self.keys, self.values, old_keys, old_values)
        self.count += _insert(self.keys, self.values, np.ascontiguousarray(keys, np.int64),
                              np.ascontiguousarray(values, float))

    def drop(self, forget) -> None:
        """Remove the entries whose keys ``forget(keys)`` marks."""
        live = self.keys != EMPTY
        keys, values = self.keys[live], self.values[live]
        kept = ~forget(keys)
        self.keys[:] = EMPTY
        self.values[:] = np.nan
        self.count = _insert(self.keys, self.values, keys[kept], values[kept])


@kernel
def horizon_azimuth(chord, up, x_axis, y_axis):
    """Azimuth ψ of a chord direction from the orbital X axis in the local horizontal, rad in [0, 2π), and
    the unit horizontal direction (3-tuples in ECI; ``up`` the unit radial)."""
    along_up = chord[0] * up[0] + chord[1] * up[1] + chord[2] * up[2]
    h = (chord[0] - along_up * up[0], chord[1] - along_up * up[1], chord[2] - along_up * up[2])
    norm = math.sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2])
    h = (h[0] / norm, h[1] / norm, h[2] / norm)
    psi = math.atan2(h[0] * y_axis[0] + h[1] * y_axis[1] + h[2] * y_axis[2],
                     h[0] * x_axis[0] + h[1] * x_axis[1] + h[2] * x_axis[2])
    return psi % (2.0 * math.pi), h


@kernel
def grid_value(grid, params, keys, values, t_s, psi, misses, count):
    """A field's value at time ``t_s`` and azimuth ``psi`` from its grid (number ``grid``, ``params``, the
    node table's ``keys`` and ``values``); each node it lacks is appended to ``misses`` as (grid, time node,
    azimuth node) from row ``count`` unless one of the last :data:`RECENT_MISSES` rows has it (the samples
    before asked for the same nodes). Returns (value — NaN if a node was missing —, the new count)."""
    position = (params[_ORIGIN] + t_s) / params[_SPACING]
    k = math.floor(position)
    wt = lagrange_weights(position - k)
    m = int(params[_AZIMUTHS])
    where = psi * m / (2.0 * math.pi)
    j = math.floor(where)
    fraction = where - j
    if fraction < ON_NODE:
        wp, first_j, nodes = (1.0, 0.0, 0.0, 0.0), int(j), 1
    elif fraction > 1.0 - ON_NODE:
        wp, first_j, nodes = (1.0, 0.0, 0.0, 0.0), int(j) + 1, 1
    else:
        wp, first_j, nodes = (1.0 - fraction, fraction, 0.0, 0.0), int(j), 2
    total = 0.0
    missing = False
    for dt in range(4):
        node = int(k) - 1 + dt
        for dj in range(nodes):
            jj = (first_j + dj) % m
            key = node * m + jj
            place = _slot(keys, key)
            if keys[place] == EMPTY:
                missing = True
                recorded = min(count, misses.shape[0])
                seen = False
                for row in range(max(0, recorded - RECENT_MISSES), recorded):
                    if misses[row, 0] == grid and misses[row, 1] == node and misses[row, 2] == jj:
                        seen = True
                        break
                if not seen:
                    if count < misses.shape[0]:
                        misses[count, 0], misses[count, 1], misses[count, 2] = grid, node, jj
                    count += 1
            else:
                total += wt[dt] * wp[dj] * values[place]
    return (math.nan if missing else total), count


class FieldGrid:
    """One field of the environment on the (time, azimuth) grid of the horizon circle.

    Args:
        spacing_s: time-node spacing Δt, s.
        origin_s: the fields' clock at simulation time 0, s (node k at simulation time k·Δt − origin).
        azimuths: azimuth nodes M around the circle (a multiple of 4).
        evaluate: ``(lat_rad, lon_rad, t_s) → values`` of the field at flat arrays of points; None: no field.
    """

    def __init__(self, spacing_s: float, origin_s: float, azimuths: int, evaluate):
        self.spacing_s, self.origin_s, self.azimuths = float(spacing_s), float(origin_s), int(azimuths)
        self.evaluate = evaluate
        self.params = np.array([self.spacing_s, self.origin_s, self.azimuths, float(evaluate is not None)])
        self.table = NodeTable()
        #: Time node → (its orbit's radial unit vector, orbital X and Y (ECI), the horizon's central angle,
        #: whether that orbit is final), for the nodes evaluated so far.
        self.rings: dict[int, np.ndarray] = {}
        #: The time nodes of :attr:`rings` placed from an extrapolated state (not final): what a followed orbit's
        #: next state can make stale, kept apart so that each new state looks at these few, not at every ring.
        self.provisional: set[int] = set()
        self.first_needed = -2**62  # the earliest time node the samples still need

    @property
    def enabled(self) -> bool:
        return self.evaluate is not None

    def node_time_s(self, node) -> np.ndarray:
        """Simulation time of time node(s) ``node``, s."""
        return np.asarray(node, float) * self.spacing_s - self.origin_s

    def node_of(self, t_s: float) -> int:
        """The time node at or before the simulation time ``t_s``."""
        return math.floor((self.origin_s + t_s) / self.spacing_s)

    def forget(self, nodes) -> None:
        """Drop the values and the orbit of time ``nodes`` (their orbit changed)."""
        nodes = set(int(k) for k in nodes)
        for k in nodes:
            self.rings.pop(k, None)
        self.provisional.difference_update(nodes)
        self.table.drop(lambda keys: np.isin(np.floor_divide(keys, self.azimuths), list(nodes)))


class HorizonFields:
    """The weather and the window-layer height along the horizon: :class:`FieldGrid` s filled as the sensor goes.

    Args:
        environment: the :class:`~pmv_ros.physics.environment.RadianceEnvironment`.
        spacing_s: (radiance, height) time-node spacings, s.
        azimuths: (radiance, height) azimuth nodes around the circle.
        earth_rotation_at_epoch_rad: Greenwich angle at simulation time 0, rad.
        track: the :class:`~pmv_ros.physics.instrument.track.OrbitTrack` whose orbit places the nodes' circles.
    """

    def __init__(self, environment, spacing_s, azimuths, earth_rotation_at_epoch_rad: float, track):
        self.environment = environment
        self.track = track
        self.earth_rotation_rad = float(earth_rotation_at_epoch_rad)
        origin = environment.parameters.field_time_origin_s
        weather, layer = environment.weather, environment.window_layer

        def anomaly(lat, lon, t):
            return weather.combine(environment.background_anomaly(lat, lon, t), environment.synoptic_band(lat, lon, t))

        self.grids = (FieldGrid(spacing_s[0], origin, azimuths[0], anomaly if weather is not None else None),
                      FieldGrid(spacing_s[1], origin, azimuths[1], layer.gaussian_field if layer else None))
        self._version = track.version

    def refresh(self) -> None:
        """A followed orbit got new states: the nodes placed from an extrapolated state are dropped (placed
        again when a sample needs them), and every node when the orbit started over."""
        if self.track.version == self._version:
            return
        reset = self.track.reset_version > self._version
        self._version = self.track.version
        for grid in self.grids:
            stale = list(grid.rings) if reset else list(grid.provisional)
            if stale:
                grid.forget(stale)

    @property
    def current(self) -> bool:
        """No node has become stale since the last :meth:`refresh` (a followed orbit's new states can make some)."""
        return self.track.version == self._version

    def kernel_inputs(self) -> tuple:
        """What the sensor's kernel reads of the two grids as they are now: their node tables' keys and values."""
        weather, height = self.grids
        return weather.table.keys, weather.table.values, height.table.keys, height.table.values

    @property
    def params(self) -> np.ndarray:
        """The two grids' parameters (4 each: spacing s, the fields' clock origin s, azimuth nodes, enabled)."""
        return np.concatenate([grid.params for grid in self.grids])

    def fill(self, misses: np.ndarray, count: int, sample_times: np.ndarray, sample_states: np.ndarray) -> None:
        """Evaluate the nodes the kernel found missing (rows (grid, time node, azimuth node) of ``misses``) for
        the samples at ``sample_times`` (s; a followed orbit's states there, :meth:`OrbitTrack.states`)."""
        self.refresh()
        first_s = float(sample_times.min())
        for index, grid in enumerate(self.grids):
            missed = misses[:count][misses[:count, 0] == index]
            if missed.size == 0:
                continue
            # (time node, azimuth node) rows once each, in the order of their keys (a 1-D sort, not of rows)
            keys = np.unique(missed[:, 1] * grid.azimuths + missed[:, 2])
            rows = np.stack(np.divmod(keys, grid.azimuths), 1)
            # and the time nodes after the last one missing at each azimuth node (NODES_AHEAD)
            order = np.lexsort((rows[:, 0], rows[:, 1]))
            last = order[np.r_[rows[order[1:], 1] != rows[order[:-1], 1], True]]
            count_ahead = NODES_AHEAD if self.track.model_orbit else NODES_AHEAD_FOLLOWED
            ahead = rows[last][:, None, :] + np.stack([np.arange(1, count_ahead + 1), np.zeros(count_ahead, int)], 1)
            ahead = ahead.reshape(-1, 2)
            ahead = ahead[_absent(grid.table.keys, np.ascontiguousarray(ahead[:, 0] * grid.azimuths + ahead[:, 1]))]
            rows = np.concatenate([rows, ahead])
            nodes, which = np.unique(rows[:, 0], return_inverse=True)
            grid.first_needed = grid.node_of(first_s) - 1
            self._rings(grid, [k for k in nodes.tolist() if k not in grid.rings], sample_times, sample_states)
            ring = np.array([grid.rings[k] for k in nodes.tolist()])[which.ravel()]
            psi = rows[:, 1] * (2.0 * math.pi / grid.azimuths)
            angle = ring[:, 9]
            direction = np.cos(psi)[:, None] * ring[:, 3:6] + np.sin(psi)[:, None] * ring[:, 6:9]
            eci = np.cos(angle)[:, None] * ring[:, 0:3] + np.sin(angle)[:, None] * direction
            t = grid.node_time_s(rows[:, 0])
            lat, lon = geocentric_latitude_longitude(eci_to_ecef(eci.T, t, self.earth_rotation_rad))
            first = grid.first_needed * grid.azimuths
            grid.table.insert(rows[:, 0] * grid.azimuths + rows[:, 1], grid.evaluate(lat, lon, t),
                              keep=lambda keys: keys >= first)

    def _rings(self, grid: FieldGrid, nodes: list, sample_times, sample_states) -> None:
        """The horizon circles of time ``nodes``: the orbit there, its frame and the central angle."""
        if not nodes:
            return
        position, velocity, final = self.track.node_states(grid.node_time_s(np.array(nodes, float)), sample_times,
                                                           sample_states)
        frame = orbital_frame_from_state(position, velocity)  # (3, 3, K): columns X, Y, Z
        radius = np.sqrt(np.sum(position * position, axis=0))
        angle = np.arccos(EARTH_MEAN_RADIUS_M / radius)
        final = np.asarray(final, float)
        rings = np.concatenate([frame[:, 2], frame[:, 0], frame[:, 1], angle[None], final[None]])  # (11, K)
        grid.rings.update(zip(nodes, np.ascontiguousarray(rings.T)))
        provisional = set(np.asarray(nodes)[final == 0.0].tolist())
        grid.provisional.difference_update(set(nodes) - provisional)
        grid.provisional.update(provisional)
        if len(grid.rings) > RINGS_KEPT:  # the rings of time nodes the samples no longer reach
            for k in [k for k in grid.rings if k < grid.first_needed]:
                del grid.rings[k]
                grid.provisional.discard(k)
