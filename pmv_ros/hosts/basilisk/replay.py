"""Recorded Basilisk states through pmv_ros off line: what the PMV and the monitor make of them, as a flight does.

A Basilisk run's ``SCStatesMsg`` recorder (``timesWritten()``, ``r_BN_N``,
``v_BN_N``, ``sigma_BN``) replayed through the sensor node's runtime in
follow mode (:func:`replay_states`) and the result through the star
tracker's and the monitor's, the way the campaign's flight does
(:func:`flight_summary`: :func:`pmv_ros.runtime.flight.tracker_frames` on the
whole truth stream, then one
:meth:`~pmv_ros.runtime.monitor.runtime.MonitorRuntime.add_stream`). For
post-processing a run recorded without the module, and the reference the
module is checked against (README "In Basilisk").
"""

from __future__ import annotations

import numpy as np

from ...runtime.common.assembly import read_correction
from ...runtime.flight import tracker_frames
from ...runtime.monitor.records import MonitorSummary
from ...runtime.monitor.runtime import MonitorRuntime
from ...runtime.sensor.runtime import SensorRuntime
from .frames import attitude_in_orbital
from .sensor import BATCH_STATES
from .values import HOST_CLOCK_OFFSET_S


def replay_states(values, times_ns, r_BN_N, v_BN_N, sigma_BN, dcm_CB, *, call_every_ns: int | None = None) -> list:
    """The PMV's samples of recorded states (``(N,)`` ns, increasing; ``(N, 3)`` each), stamped on the runtime's
    clock (:data:`~pmv_ros.hosts.basilisk.values.HOST_CLOCK_OFFSET_S` after Basilisk's).

    Every state is fed as the truth and the odometry of its time; the samples are taken at the states on the
    sensor's grid. ``call_every_ns``: the period of the module's calls when it runs in a slower task and is
    given the states since its last call (:meth:`PmvHorizonSensor.batchStates`): those are sensed as blocks
    of up to :data:`BATCH_STATES`, as the module senses them (states after its last call are not); None: a
    module called at every state.
    ``values``: every node's values (:func:`~pmv_ros.hosts.basilisk.values.host_values`).
    """
    sensor = values.sensor
    runtime = SensorRuntime(sensor, clock_epoch_s=HOST_CLOCK_OFFSET_S, correction=read_correction(sensor))
    period_ns = round(1e9 / sensor["sensor.rate_hz"])
    times_ns = np.asarray(times_ns, np.int64).tolist()
    q = attitude_in_orbital(r_BN_N, v_BN_N, sigma_BN, dcm_CB)
    samples, due, fed = [], [], 0
    for k, time_ns in enumerate(times_ns):
        t_s = time_ns * 1e-9 + HOST_CLOCK_OFFSET_S
        runtime.add_truth(runtime.frames.orbital, t_s, q[:, k], t_s)
        runtime.add_odometry(runtime.frames.eci, runtime.frames.orbital, (t_s, r_BN_N[k], v_BN_N[k]), t_s)
        fed += 1
        if time_ns % period_ns == 0:
            due.append(t_s)
        call = call_every_ns is None or time_ns % call_every_ns == 0  # the module runs after this state
        if call or fed == BATCH_STATES:
            samples += runtime.step_to(due).samples
            due, fed = [], 0
    return samples


def flight_summary(values, samples) -> MonitorSummary:
    """The monitor's statistics of ``samples`` (the sensor's, in order) against the truth they were measured
    at, through the star tracker: as :func:`pmv_ros.runtime.flight.fly` computes them."""
    t = np.array([s.t_s for s in samples])
    q = np.array([s.q_xyzw for s in samples]).T
    frames = tracker_frames(t, q, values.star_tracker, start_s=HOST_CLOCK_OFFSET_S)
    published = np.flatnonzero(frames.released_at >= 0)
    monitor = MonitorRuntime(values.monitor)
    monitor.add_stream(t, np.array([s.roll_rad for s in samples]), np.array([s.pitch_rad for s in samples]),
                       frames.frame_s[published], frames.q_measured[:, published], frames.released_at[published],
                       np.array([s.position_eci_m for s in samples]).T,
                       np.array([s.velocity_eci_m_s for s in samples]).T)
    return monitor.monitor.summary()
