"""The error monitor on a Basilisk run: the PMV's readings against Basilisk's truth, as the nodes compute it.

:class:`PmvErrorMonitor` is what ``star_tracker_node`` and
``error_monitor_node`` make of the PMV's samples, run on their own runtimes
(:class:`~pmv_ros.runtime.tracker.runtime.TrackerRuntime`,
:meth:`~pmv_ros.runtime.monitor.runtime.MonitorRuntime.add_stream`) the way
the campaign's flight runs them (:mod:`pmv_ros.runtime.flight`): the true
attitude each sample was measured at goes through the star tracker (its
frames, noise, failures and latency from the preset), the released frames
reach the monitor just before the sample of their step, and the orbit state
at each sample is its odometry. Samples are taken in blocks of
:data:`BLOCK` (a block is one batch; how a stream is cut into batches
changes nothing but the order of sums). Read it after a run, as a
recorder: :meth:`PmvErrorMonitor.summary` (mean, σ, 3σ, harmonics per
channel, physics.md §5) and the residuals of the samples used.
"""

from __future__ import annotations

import numpy as np

from ...runtime.monitor.records import MonitorSummary, Status
from ...runtime.monitor.runtime import MonitorRuntime
from ...runtime.tracker.runtime import TrackerRuntime

#: Samples kept before they are fed as one batch.
BLOCK = 512


class PmvErrorMonitor:
    """The residual statistics of a :class:`~pmv_ros.hosts.basilisk.sensor.PmvHorizonSensor`'s samples.

    Made by :meth:`PmvHorizonSensor.errorMonitor`; fed by the sensor; emptied when the simulation is
    initialised. ``values``: every node's parameter values (the sensor's ``host_values``); ``start_s``: the
    runtime clock at Basilisk's time 0 (the star tracker's outages count from it).
    """

    def __init__(self, values, start_s: float):
        self.start_s = float(start_s)
        self.reset(values)

    def reset(self, values) -> None:
        """Start over with ``values`` (every node's parameter values)."""
        self.values = values
        self.tracker = TrackerRuntime(values.star_tracker, self.start_s)
        self.monitor = MonitorRuntime(values.monitor)
        self._pending = []
        self._residuals = []  # (3, n) arrays: stamp s, residual roll, residual pitch (rad) of the samples used

    def add_samples(self, samples) -> None:
        """Take the sensor's samples (:class:`~pmv_ros.runtime.sensor.sample_stream.SensorSample`, in order)."""
        self._pending.extend(samples)
        if len(self._pending) >= BLOCK:
            self.flush()

    def flush(self) -> None:
        """Feed the samples taken so far to the star tracker and the monitor, as one batch."""
        if not self._pending:
            return
        rows, self._pending = self._pending, []
        t = np.array([s.t_s for s in rows])
        q = np.array([s.q_xyzw for s in rows]).T
        buffer = self.tracker.orbit_buffer  # orbit.source follow (the host's): the samples' states are its odometry
        if buffer is not None:
            for row in rows:
                buffer.add(row.t_s, row.position_eci_m, row.velocity_eci_m_s)
        self.tracker.add_truth_batch(t, q)
        frame_s, q_measured, arrival = self.tracker.release_batch(t)  # each released at a sample's stamp
        batch = self.monitor.add_stream(t, np.array([s.roll_rad for s in rows]), np.array([s.pitch_rad for s in rows]),
                                        frame_s, q_measured, arrival, np.array([s.position_eci_m for s in rows]).T,
                                        np.array([s.velocity_eci_m_s for s in rows]).T)
        earlier = [(o.stamp_s, o.residual_roll_rad, o.residual_pitch_rad) for o in batch.earlier
                   if o.status is Status.OK]  # samples of earlier batches that waited for truth
        if earlier:
            self._residuals.append(np.array(earlier).T)
        used = np.flatnonzero(batch.status == 0)  # code 0 is OK
        self._residuals.append(np.stack([t[used], batch.residual_roll_rad[used], batch.residual_pitch_rad[used]]))

    def summary(self, oblateness_removed: bool | None = None) -> MonitorSummary:
        """The statistics of every sample so far (``oblateness_removed``: which set; None: as configured)."""
        self.flush()
        return self.monitor.monitor.summary(oblateness_removed)

    def residuals(self):
        """The samples used so far: (Basilisk times s, residual roll, residual pitch rad: sensed − true), in
        stamp order."""
        self.flush()
        stamps, roll, pitch = np.concatenate([np.empty((3, 0))] + self._residuals, axis=1)
        order = np.argsort(stamps, kind="stable")
        return stamps[order] - self.start_s, roll[order], pitch[order]
