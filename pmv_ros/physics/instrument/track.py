"""What the sensor needs that does not depend on the attitude: the orbit and the Sun and Moon along the track.

The orbit state, the orbital frame and the directions of the Sun and the
Moon are functions of time alone. :class:`OrbitTrack` evaluates them once at
nodes of a fixed time grid — every :data:`TRACK_NODE_S` seconds of the
simulation clock, in chunks of :data:`TRACK_CHUNK` nodes computed ahead as the
samples reach them — and the sensor's kernel interpolates each sample's state
from the four nodes around it (a cubic through them: Lagrange's form). The
nodes are where they are whatever samples ask, so a sample's state does not
depend on how the samples are grouped into calls, and a sample at any time
(a host's own clock, a truth message's stamp) costs no orbit evaluation of
its own.

Accuracy of the interpolation (a cubic through nodes 2 s apart, on an orbit
of mean motion n and radius r): ≈ (n·h)⁴·r·9/384 in position — ≈ 4·10⁻⁶ m
in low orbit — and the direction of the velocity to ≈ 10⁻¹² rad;
the Moon's geocentric position moves 10⁻⁶ of its orbit in 2 s.

An orbit followed from messages (any other than the physics' own
:class:`~pmv_ros.physics.orbit.two_body.CircularOrbit`,
:class:`~pmv_ros.physics.orbit.two_body.KeplerOrbit` and
:class:`~pmv_ros.physics.orbit.tle.TleOrbit`) is no function of time known
ahead: each sample's state is asked of it, and the field nodes' orbit
(:meth:`OrbitTrack.node_states`) is the nearest sample's state carried to the
node's time; whoever feeds the orbit says how far its states are final — not
extrapolated — (:meth:`OrbitTrack.follow`), and a node carried from a state
that was extrapolated is placed again when new states arrive.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import kernel
from ..constants import GM_EARTH_M3_S2
from ..orbit.ephemeris import Epoch, moon_position_eci_m, sun_position_eci_m
from ..orbit.tle import OrbitPropagationError, TleOrbit
from ..orbit.two_body import CircularOrbit, KeplerOrbit

#: Spacing of the track's nodes on the simulation clock, s (see the module docstring for the accuracy).
TRACK_NODE_S = 2.0
#: Nodes computed at once (≈ 8.5 min of track): the chunks are aligned to the grid, so a node's value
#: is computed the same way whichever sample first asks for it.
TRACK_CHUNK = 256
#: Most chunks kept (≈ 2.3 h of track): beyond, the chunks a call needs replace those held.
TRACK_CHUNKS_KEPT = 16
#: Columns of a track row: position (m), velocity (m/s), the Sun's and the Moon's geocentric positions (m), ECI.
TRACK_COLUMNS = 12
#: The states of a model orbit's samples: none (the kernel interpolates its track).
NO_STATES = np.empty((0, 6))


@kernel
def lagrange_weights(fraction):
    """Weights of the cubic through nodes −1, 0, 1, 2 at ``fraction`` ∈ [0, 1) past node 0 (Lagrange's form)."""
    u = fraction
    return (-u * (u - 1.0) * (u - 2.0) / 6.0, (u + 1.0) * (u - 1.0) * (u - 2.0) / 2.0,
            -(u + 1.0) * u * (u - 2.0) / 2.0, (u + 1.0) * u * (u - 1.0) / 6.0)


@kernel
def track_weights(t_s, first_node, spacing_s):
    """Where sample time ``t_s`` falls on a track of nodes ``first_node``, … every ``spacing_s``: the node
    row of the first of its four nodes, and their weights."""
    position = t_s / spacing_s
    k = math.floor(position)
    return int(k) - 1 - first_node, lagrange_weights(position - k)


@kernel
def _interpolate(times, nodes, first_node, spacing_s, first_column, out):
    """Rows of ``out`` (N, 12): the node rows' columns from ``first_column`` on, interpolated to ``times``."""
    for n in range(times.size):
        row, w = track_weights(times[n], first_node, spacing_s)
        for column in range(first_column, nodes.shape[1]):
            out[n, column] = (w[0] * nodes[row, column] + w[1] * nodes[row + 1, column]
                              + w[2] * nodes[row + 2, column] + w[3] * nodes[row + 3, column])


class OrbitTrack:
    """The orbit (and the Sun and Moon) of a sensor on a fixed time grid, interpolated to its samples.

    Args:
        orbit: the orbit, any with ``state_eci(t_s)`` (position m, velocity m/s, ECI, ``(3, N)``).
        epoch: the UTC instant at simulation time 0, to place the Sun and the Moon; None: not placed
            (their columns are NaN).
    """

    def __init__(self, orbit, epoch: Epoch | None = None):
        self.orbit = orbit
        self.epoch = epoch
        #: The orbit is a function of time known ahead (its nodes are computed and interpolated).
        self.model_orbit = isinstance(orbit, (CircularOrbit, KeplerOrbit, TleOrbit))
        self._first_node = 0
        self._nodes = np.empty((0, TRACK_COLUMNS))
        self._params = np.array([0.0, TRACK_NODE_S, 0.0 if self.model_orbit else 1.0])
        self._errors: dict[int, OrbitPropagationError] = {}  # node → SGP4's error there

    #: Bumped by :meth:`follow`: earlier answers of :meth:`node_states` may no longer hold.
    version = 0
    #: Samples at or before this time have their final state (a followed orbit: its newest message), s.
    final_until_s = math.inf
    #: The :attr:`version` at which a followed orbit last started over (every state before is void).
    reset_version = 0

    def follow(self, final_until_s: float, reset: bool = False) -> None:
        """A followed orbit got a new state: states at or before ``final_until_s`` (s) are final from now on;
        ``reset``: it started over (a new timeline), so nothing given before holds."""
        self.version += 1
        self.final_until_s = float(final_until_s)
        if reset:
            self.reset_version = self.version

    def _chunk(self, chunk: int) -> np.ndarray:
        """The node rows of one chunk (orbit, Sun, Moon); a node SGP4 cannot propagate is NaN (error kept)."""
        first = chunk * TRACK_CHUNK
        times = (first + np.arange(TRACK_CHUNK)) * TRACK_NODE_S
        rows = np.full((TRACK_CHUNK, TRACK_COLUMNS), np.nan)
        if self.model_orbit:
            try:
                position, velocity = self.orbit.state_eci(times)
                rows[:, 0:3], rows[:, 3:6] = position.T, velocity.T
            except OrbitPropagationError:  # node by node, keeping each error
                for k, t in enumerate(times):
                    try:
                        position, velocity = self.orbit.state_eci(np.array([t]))
                        rows[k, 0:3], rows[k, 3:6] = position[:, 0], velocity[:, 0]
                    except OrbitPropagationError as error:
                        self._errors[first + k] = error
        if self.epoch is not None:
            jd_tt = self.epoch.julian_date_tt(times)
            rows[:, 6:9] = sun_position_eci_m(jd_tt).T
            rows[:, 9:12] = moon_position_eci_m(jd_tt).T
        return rows

    def kernel_inputs(self) -> tuple:
        """What the sensor's kernel reads of the track: the node rows (M, 12) and (first node, spacing s,
        1 if the orbit is followed)."""
        return self._nodes, self._params

    @property
    def has_errors(self) -> bool:
        """Some node SGP4 could not propagate (:meth:`needs` raises its error for samples near it)."""
        return bool(self._errors)

    def needs(self, first_node: int, last_node: int) -> None:
        """Have the nodes ``first_node`` … ``last_node`` (the kernel asked for them); raise SGP4's error
        where one of them could not be propagated."""
        self._cover(first_node, last_node)
        failed = [k for k in self._errors if first_node <= k <= last_node]
        if failed:
            raise self._errors[min(failed)]

    def _cover(self, first_node: int, last_node: int) -> None:
        """Have the nodes ``first_node`` … ``last_node`` (whole chunks): the chunks held so far and these, or
        these alone when together they would be more than :data:`TRACK_CHUNKS_KEPT`."""
        first_chunk, last_chunk = first_node // TRACK_CHUNK, last_node // TRACK_CHUNK
        have_first = self._first_node // TRACK_CHUNK
        have_last = have_first + self._nodes.shape[0] // TRACK_CHUNK - 1
        if have_first <= first_chunk and last_chunk <= have_last:
            return
        if have_last >= have_first and max(last_chunk, have_last) - min(first_chunk, have_first) < TRACK_CHUNKS_KEPT:
            first_chunk, last_chunk = min(first_chunk, have_first), max(last_chunk, have_last)
        parts = []
        for chunk in range(first_chunk, last_chunk + 1):
            if have_first <= chunk <= have_last:
                start = (chunk - have_first) * TRACK_CHUNK
                parts.append(self._nodes[start:start + TRACK_CHUNK])
            else:
                parts.append(self._chunk(chunk))
        self._nodes = np.concatenate(parts)
        self._first_node = first_chunk * TRACK_CHUNK
        self._params = np.array([self._first_node, TRACK_NODE_S, 0.0 if self.model_orbit else 1.0])
        self._errors = {k: e for k, e in self._errors.items() if k >= self._first_node}

    def rows(self, times: np.ndarray) -> np.ndarray:
        """``(N, 12)`` rows at ``times`` (s, finite): position, velocity, Sun, Moon (ECI, m and m/s) — for a
        followed orbit the Sun and the Moon only (its states are the follower's).

        Raises :class:`~pmv_ros.physics.orbit.tle.OrbitPropagationError` when a node a sample needs could
        not be propagated.
        """
        self.needs(math.floor(float(times.min()) / TRACK_NODE_S) - 1, math.floor(float(times.max()) / TRACK_NODE_S) + 2)
        out = np.full((times.size, TRACK_COLUMNS), np.nan)
        _interpolate(times, self._nodes, self._first_node, TRACK_NODE_S, 0 if self.model_orbit else 6, out)
        return out

    def states(self, times: np.ndarray) -> np.ndarray:
        """``(N, 6)`` position and velocity a followed orbit gives at ``times`` (it raises where it has none);
        ``(0, 6)`` for a model orbit, whose states the kernel interpolates from the nodes."""
        if self.model_orbit:
            return NO_STATES
        position, velocity = self.orbit.state_eci(times)
        return np.ascontiguousarray(np.concatenate([position, velocity]).T)

    def node_states(self, times: np.ndarray, sample_times: np.ndarray, sample_states: np.ndarray):
        """Position (m) and velocity (m/s), ``(3, K)``, at the field nodes' ``times``, and whether each is
        final. A model orbit's are its track's (:meth:`rows`; final); a followed orbit's are the state of the
        nearest of the samples (``sample_times``, their :meth:`states`) carried to the node's time
        (:func:`carried_state`), final if that sample's state was."""
        if self.model_orbit:
            rows = self.rows(times)
            return rows[:, 0:3].T, rows[:, 3:6].T, np.ones(times.size, bool)
        nearest = np.abs(times[:, None] - sample_times[None, :]).argmin(axis=1)
        position, velocity = np.empty((3, times.size)), np.empty((3, times.size))
        for n, k in enumerate(nearest.tolist()):
            position[:, n], velocity[:, n] = carried_state(sample_states[k, 0:3], sample_states[k, 3:6],
                                                           float(times[n] - sample_times[k]))
        return position, velocity, sample_times[nearest] <= self.final_until_s


def carried_state(position_m, velocity_m_s, dt_s: float):
    """A state carried ``dt_s`` (a few seconds) along its orbit to place a field node: in its orbit plane, the
    angle and the radius to second order in time under the point mass (θ̈ = −2ṙθ̇/r, r̈ = rθ̇² − μ/r²);
    position m and velocity m/s (the velocity only turned with the plane's angle).

    For a node's horizon circle only: on an orbit of eccentricity 0.3 it misses the two-body motion by
    ≈ 0.6 m after 8 s at perigee (tests/physics/test_track.py), against field scales of ≥ 100 km.
    """
    r = np.asarray(position_m, float)
    v = np.asarray(velocity_m_s, float)
    radius = math.sqrt(float(r @ r))
    normal = np.cross(r, v)
    axis = normal / math.sqrt(float(normal @ normal))
    rate = math.sqrt(float(normal @ normal)) / radius**2  # θ̇
    radial = float(r @ v) / radius  # ṙ
    angle = rate * dt_s - rate * radial / radius * dt_s**2
    new_radius = radius + radial * dt_s + 0.5 * (radius * rate**2 - GM_EARTH_M3_S2 / radius**2) * dt_s**2
    c, s = math.cos(angle), math.sin(angle)

    def turned(vector):
        return vector * c + np.cross(axis, vector) * s + axis * float(axis @ vector) * (1.0 - c)

    return turned(r) * (new_radius / radius), turned(v)
