"""Recorded Basilisk states through pmv_ros off line: what the PMV and the monitor make of them, as a flight does.

A Basilisk run's ``SCStatesMsg`` recorder (``timesWritten()``, ``r_BN_N``,
``v_BN_N``, ``sigma_BN``) replayed through the sensor node's runtime in
follow mode (:func:`replay_states`) and the result through the star
tracker's and the monitor's, the way the campaign's flight does
(:func:`flight_summary`: :func:`pmv_ros.runtime.flight.tracker_frames` on the
whole truth stream, then one
:meth:`~pmv_ros.runtime.monitor.runtime.MonitorRuntime.add_stream`). For
post-processing a run recorded without the module, and the reference the
module is checked against (docs/basilisk.md).
"""

from __future__ import annotations

import numpy as np

from ...runtime.common.assembly import read_correction
from ...runtime.flight import tracker_frames
from ...runtime.monitor.records import MonitorSummary
from ...runtime.monitor.runtime import MonitorRuntime
from ...runtime.sensor.runtime import SensorRuntime
from .frames import attitude_in_orbital
from .values import HOST_CLOCK_OFFSET_S, SampleClock


def replay_states(values, times_ns, r_BN_N, v_BN_N, sigma_BN, dcm_CB) -> list:
    """The PMV's samples of recorded states (``(N,)`` ns, increasing; ``(N, 3)`` each), stamped on the runtime's
    clock (:data:`~pmv_ros.hosts.basilisk.values.HOST_CLOCK_OFFSET_S` after Basilisk's).

    Every state is fed, in order, as the truth and the odometry of its time; after each one the runtime
    measures at the sample times (:class:`~pmv_ros.hosts.basilisk.values.SampleClock`) it reached, from the
    first state on — what :class:`~pmv_ros.hosts.basilisk.sensor.PmvHorizonSensor` measures in a simulation
    that wrote these states, by another way (the module feeds only the states around each sample).
    ``values``: every node's values (:func:`~pmv_ros.hosts.basilisk.values.host_values`).
    """
    sensor = values.sensor
    runtime = SensorRuntime(sensor, clock_epoch_s=HOST_CLOCK_OFFSET_S, correction=read_correction(sensor))
    clock = SampleClock(sensor["sensor.rate_hz"])
    times_ns = np.asarray(times_ns, np.int64).tolist()
    q = attitude_in_orbital(r_BN_N, v_BN_N, sigma_BN, dcm_CB).T.tolist()
    r, v = np.asarray(r_BN_N, float).tolist(), np.asarray(v_BN_N, float).tolist()
    samples, index = [], clock.first_index_at_or_after(times_ns[0]) if times_ns else 0
    for k, time_ns in enumerate(times_ns):
        t_s = time_ns * 1e-9 + HOST_CLOCK_OFFSET_S
        runtime.add_odometry(runtime.frames.eci, runtime.frames.orbital, (t_s, r[k], v[k]), t_s)
        runtime.add_truth(runtime.frames.orbital, t_s, q[k], t_s)
        due = []
        while clock.time_ns(index) <= time_ns:
            due.append(clock.time_ns(index) * 1e-9 + HOST_CLOCK_OFFSET_S)
            index += 1
        if due:
            samples += runtime.step_to(due).samples
    return samples


def flight_summary(values, samples) -> MonitorSummary:
    """The monitor's statistics of ``samples`` (the sensor's, in order) against the truth they were measured
    at, through the star tracker: as :func:`pmv_ros.runtime.flight.fly` computes them."""
    t = np.array([s.t_s for s in samples])
    q = np.array([s.q_xyzw for s in samples]).T
    position = np.array([s.position_eci_m for s in samples]).T
    velocity = np.array([s.velocity_eci_m_s for s in samples]).T
    frames = tracker_frames(t, q, values.star_tracker, start_s=HOST_CLOCK_OFFSET_S, orbit_states=(position, velocity))
    published = np.flatnonzero(frames.released_at >= 0)
    monitor = MonitorRuntime(values.monitor)
    monitor.add_stream(t, np.array([s.roll_rad for s in samples]), np.array([s.pitch_rad for s in samples]),
                       frames.frame_s[published], frames.q_measured[:, published], frames.released_at[published],
                       position, velocity)
    return monitor.monitor.summary()
