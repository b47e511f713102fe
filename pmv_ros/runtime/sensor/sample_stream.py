"""The sensor's output sample by sample, as plain values a node publishes — computed in blocks when it can.

:class:`SampleStream` runs :class:`pmv_ros.physics.instrument.sensor.SensorModel` for the
sensor node: with the node's own attitude profile it computes a block of
future samples in one call (the per-call cost amortised), with a given
attitude (follow mode) the samples due, one or more. A sample reads the same
in any block (the instrument's grids are fixed on the clock). Each sample is a
:class:`SensorSample` of Python floats and tuples, so publishing does no numpy
indexing.
"""

from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple

import numpy as np

from ...physics.instrument.sensing import BLINDING, LINE_OF_SIGHT, PITCH, PITCH_UNCORRECTED, POSITION, ROLL, \
    ROLL_UNCORRECTED, STATUS, VELOCITY
from ...physics.instrument.sensor import ChordStatus


class SensorSample(NamedTuple):
    """One sample of the sensor as its node publishes it: Python floats and tuples, SI units and radians."""

    t_s: float  #: the sample's stamp
    q_xyzw: tuple  #: attitude of the body in the orbital frame (x, y, z, w)
    line_of_sight: tuple  #: 4 × (x, y, z) unit lines of sight to the crossings in the sensor frame (NaN: lost)
    roll_rad: float  #: sensed roll (REP-103), brightness-corrected; NaN when a chord pair is lost
    pitch_rad: float  #: sensed pitch
    roll_uncorrected_rad: float  #: sensed roll before the brightness correction
    pitch_uncorrected_rad: float
    chord_status: tuple  #: 4 :class:`~pmv_ros.physics.instrument.sensor.ChordStatus` codes
    blinding_body: tuple  #: 4 indices into :data:`~pmv_ros.physics.orbit.ephemeris.BODY_NAMES` (−1: none)
    position_eci_m: tuple  #: spacecraft position in ECI
    velocity_eci_m_s: tuple  #: spacecraft velocity in ECI

    @property
    def chord_valid(self) -> tuple:
        """Per chord, whether it saw a horizon (its status is VALID; the others' lines of sight are NaN)."""
        return tuple(code == ChordStatus.VALID for code in self.chord_status)


#: Samples computed per call in fast time with the own attitude profile (the per-call cost of the instrument,
#: a few µs, and of the environment's node evaluations amortised; benchmarks/bench_sensing.py). A parameter
#: change discards the block.
FAST_TIME_BLOCK = 512

#: Paced fast time: a block should take no longer than one tick, or /clock stops while it
#: is computed. Blocks are sized with this cost per sample (the slow end of these machines).
PACED_SAMPLE_COST_S = 100e-6


def fast_time_block(rate_hz: float, time_scale: float, stepped: bool) -> int:
    """Samples per block in fast time: FAST_TIME_BLOCK when stepped by a caller or unpaced
    (``time_scale`` 0), else no longer than one tick (16 … FAST_TIME_BLOCK)."""
    if time_scale == 0.0 or stepped:
        return FAST_TIME_BLOCK
    tick_s = 1.0 / (rate_hz * time_scale)
    return max(16, min(FAST_TIME_BLOCK, int(tick_s / PACED_SAMPLE_COST_S)))


def block_times(first_s: float, period_s: float, block: int) -> np.ndarray:
    """The stamps of a block of own-profile samples computed ahead: ``first_s + period_s·k``, k = 0 … block − 1, s."""
    return first_s + period_s * np.arange(block)


#: Grid times within this fraction of a period after the clock reading are due already: a clock
#: stepping by whole periods lands on the grid up to rounding (1 s = 10 × 0.1 s in binary floats).
GRID_TOLERANCE = 1e-6


#: The columns of a reading's row a sample is made of (pmv_ros.physics.instrument.sensing), by name.
_S0, _S1, _S2, _S3, _S4, _S5, _S6, _S7, _S8, _S9, _S10, _S11 = range(LINE_OF_SIGHT.start, LINE_OF_SIGHT.stop)
_C0, _C1, _C2, _C3 = range(STATUS.start, STATUS.stop)
_B0, _B1, _B2, _B3 = range(BLINDING.start, BLINDING.stop)
_P0, _P1, _P2 = range(POSITION.start, POSITION.stop)
_V0, _V1, _V2 = range(VELOCITY.start, VELOCITY.stop)


class SampleGrid:
    """The sensor's own sample times on a clock it does not step: ``epoch_s + k·period_s``, k = 1, 2, …

    A real-time sensor (the wall clock, or a ``/clock`` someone else
    publishes) asks :meth:`due` at each tick of its timer. However far the
    clock moved since the last tick — a tenth of a period or ten seconds of
    a simulation clock stepping in big strides — it gets every grid index
    since the last sample, in order, each sample to be stamped with its own
    time (interfaces.md "Time"). The first tick, and the first after
    :meth:`restart` (a confirmed clock jump), gives only the latest grid
    time: a clock that leapt is not back-filled. A clock that stepped back
    less than a jump gives nothing until it passes the last sample again.

    Sample k is the k-th step of a fast-time run that started at ``epoch_s``
    (:meth:`pmv_ros.runtime.sensor.runtime.SensorRuntime.step`): the same
    instants (:meth:`SampleStream.grid_profile_samples`).

    Args:
        epoch_s: the grid's origin, s (the node clock at the start: the orbit's epoch).
        period_s: the sample period, s.
    """

    def __init__(self, epoch_s: float, period_s: float):
        if not (math.isfinite(epoch_s) and math.isfinite(period_s) and period_s > 0.0):
            raise ValueError(f"a sample grid needs a finite epoch and a period > 0 s, not {epoch_s}, {period_s}")
        self.epoch_s, self.period_s = float(epoch_s), float(period_s)
        self.last_index: int | None = None

    def restart(self) -> None:
        """Forget the last sample: the next :meth:`due` starts at the clock (after a confirmed jump)."""
        self.last_index = None

    def with_period(self, period_s: float) -> "SampleGrid":
        """The same origin with another period (a rate change): the next sample is the first of the new grid
        after the last one."""
        grid = SampleGrid(self.epoch_s, period_s)
        if self.last_index is not None:
            grid.last_index = grid.index_at(self.time_of(self.last_index))
        return grid

    def index_at(self, t_s: float) -> int:
        """The last grid index at or before ``t_s`` (with :data:`GRID_TOLERANCE`)."""
        return math.floor((t_s - self.epoch_s) / self.period_s + GRID_TOLERANCE)

    def time_of(self, index) -> float | np.ndarray:
        """The time of grid index (or ``(N,)`` indices) ``index``, s."""
        return self.epoch_s + self.period_s * np.asarray(index, float)

    def due(self, now_s: float) -> range:
        """The grid indices due at clock reading ``now_s`` and not yet given, in order (maybe none)."""
        last = self.index_at(now_s)
        first = last if self.last_index is None else self.last_index + 1
        if last < first:
            return range(0)
        self.last_index = last
        return range(first, last + 1)


class SampleStream:
    """Sample rows of one sensor: its model, orbit and attitude profile.

    Args:
        model: the instrument (:class:`pmv_ros.physics.instrument.sensor.SensorModel`).
        orbit: the orbit it flies (for position and velocity).
        profile: the own attitude model (``quaternion(t_s)``), used by :meth:`next_profile_sample`.

    The lines of sight are the instrument's (unit vectors; NaN for a chord that is not VALID); the node checks
    them as a message's at publication, when anyone subscribes.
    """

    def __init__(self, model, orbit, profile):
        self.model, self.orbit, self.profile = model, orbit, profile
        self._pending = deque()
        self._grid_block = (None, None, [])  # real time: (grid, block number, its samples)

    @property
    def pending(self) -> int:
        """Samples computed ahead and not yet taken (at most one block)."""
        return len(self._pending)

    def clear(self) -> None:
        """Drop the precomputed samples (the models changed)."""
        self._pending.clear()

    def profile_block(self, first_s: float, period_s: float, block: int):
        """The own profile's block of ``block`` samples from ``first_s`` (:func:`block_times`): (stamps
        ``(block,)`` s, attitude ``(4, block)``, the instrument's reading) — what a sensor in fast time computes
        ahead at the first step of a block, sample by sample (:meth:`next_profile_sample`) or whole (a flight)."""
        times = block_times(first_s, period_s, block)
        q = self.profile.quaternion(times)
        return times, q, self.model.sense(times, q)

    def next_profile_sample(self, t_s: float, period_s: float, block: int) -> SensorSample:
        """The own-profile sample at ``t_s``, from the pending block or a new one of ``block`` samples."""
        if not self._pending:
            self._pending = deque(self.rows(*self.profile_block(t_s, period_s, block)))
        return self._pending.popleft()

    def grid_profile_samples(self, grid: SampleGrid, indices: range) -> list[SensorSample]:
        """Own-profile samples at the grid ``indices`` (real time: the samples a clock step made due).

        Computed ahead in the grid's blocks of :data:`FAST_TIME_BLOCK` samples —
        indices 1 … 512, 513 … 1024, … — and the current block kept: one call a
        block. A sample reads the same in any block, so a run on any clock senses
        what fast time senses.
        """
        samples = []
        for index in indices:
            number, offset = divmod(index - 1, FAST_TIME_BLOCK)
            kept_grid, kept_number, block = self._grid_block
            if kept_grid is not grid or kept_number != number:
                times = grid.time_of(np.arange(number * FAST_TIME_BLOCK + 1, (number + 1) * FAST_TIME_BLOCK + 1))
                block = self.rows(times, self.profile.quaternion(times))
                self._grid_block = (grid, number, block)
            samples.append(block[offset])
        return samples

    def samples(self, times, q_xyzw) -> list[SensorSample]:
        """Samples at ``times`` (s) with the attitudes ``q_xyzw`` (x, y, z, w each) — follow mode: one sample or
        many, the same code (a sample reads the same in any block). ``times``: a list of floats; ``q_xyzw``: a list
        of four floats each. The samples keep them as given, so a caller passes Python floats, not numpy's."""
        table = self.model.sense_rows(np.array(times, float), np.array(q_xyzw, float).reshape(-1, 4))
        return _rows(times, q_xyzw, table)

    def rows(self, times: np.ndarray, q: np.ndarray, reading=None) -> list[SensorSample]:
        """Run the instrument for ``(N,)`` times and ``(4, N)`` attitudes (or take its ``reading`` of them):
        N samples, made from the reading's rows (:attr:`~pmv_ros.physics.instrument.sensor.SensorReading.table`)."""
        if reading is None:
            reading = self.model.sense(times, q)
        return _rows(reading.t_s.tolist(), reading.q_orbital_to_body.T.tolist(), reading.table)


def _rows(times, attitudes, table: np.ndarray) -> list[SensorSample]:
    """A :class:`SensorSample` for each of ``times`` (floats, s), ``attitudes`` (x, y, z, w each) and the instrument's
    ``table`` rows."""
    samples = []
    for t_s, q_xyzw, row in zip(times, attitudes, table.tolist()):
        sight = ((row[_S0], row[_S1], row[_S2]), (row[_S3], row[_S4], row[_S5]), (row[_S6], row[_S7], row[_S8]),
                 (row[_S9], row[_S10], row[_S11]))
        samples.append(SensorSample(t_s, tuple(q_xyzw), sight, row[ROLL], row[PITCH], row[ROLL_UNCORRECTED],
                                    row[PITCH_UNCORRECTED],
                                    (int(row[_C0]), int(row[_C1]), int(row[_C2]), int(row[_C3])),
                                    (int(row[_B0]), int(row[_B1]), int(row[_B2]), int(row[_B3])),
                                    (row[_P0], row[_P1], row[_P2]), (row[_V0], row[_V1], row[_V2])))
    return samples
