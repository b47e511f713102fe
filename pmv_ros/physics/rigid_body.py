"""A rigid spacecraft's attitude relative to the orbital frame, and the PD law that holds it nadir-pointing.

The plant of the closed loop (``pmv simulate --closed-loop``; physics.md §2.1: with this sensor in the
loop, the attitude settles to minus the sensor's error within the controller's bandwidth).

State, for one body or N at once
    ``q`` — the body's attitude in the orbital frame, (x, y, z, w), the convention of
    :mod:`pmv_ros.physics.attitude` (REP-103 roll, pitch, yaw);
    ``rate`` — the body's angular velocity relative to the orbital frame, body components, rad/s (what a
    gyro reads once the orbital rate is taken out).
    Each is a sequence of components: a tuple of floats for one body (the node's path: plain float
    arithmetic, no array built) or an array ``(4, N)`` / ``(3, N)`` for N bodies (a test sweeps many
    frequencies in one integration). The same operators serve both; results come back as tuples of
    components of the same kind.

Dynamics (Wertz (ed.), *Spacecraft Attitude Determination and Control*, 1978: §16.1 quaternion
kinematics, §16.2 Euler's equations, §17.2 the gravity-gradient torque)
    The orbital frame (Z up along the radius, X towards the velocity, Y = Z × X the orbit normal) turns
    at the mean motion n about its +Y: in body axes ω_o = n·Rᵀ·ŷ. The body's inertial rate is
    ω = rate + ω_o, and with J the (diagonal) inertia

        J·ω̇ = τ − ω × J·ω,   τ = τ_control + τ_disturbance + 3n²·(ẑ × J·ẑ),   ẑ = Rᵀ·(0, 0, 1),
        d(rate)/dt = ω̇ + rate × ω_o        (ω_o is fixed in the orbital frame),
        q̇ = ½·q ⊗ (rate, 0).

    Small pitch θ alone gives J_y·θ̈ = −3n²(J_x − J_z)·θ: the pitch libration of a gravity-gradient
    satellite (stable for J_x > J_z; tests/physics/test_rigid_body.py checks its frequency).
    The orbit is taken circular at the mean motion n: the sensor's orbit (J2 node drift, an element
    set's eccentricity) turns the orbital frame differently by ≲ 1e-6 rad/s, which moves the plant's
    gyroscopic and gravity-gradient torques by that fraction of n — nothing the loop can see.

Integration
    Classical Runge–Kutta (4th order) with the torque held over the step (the controller's zero-order
    hold); the quaternion is normalised after each step.

Control (:func:`pd_torque`)
    τ = −K_p·e − K_d·rate per axis, e = (roll, pitch, yaw) error, K_p = J·ω_n², K_d = 2ζ·J·ω_n
    (ω_n = 2π × bandwidth). Each axis then closes as J·θ̈ + K_d·θ̇ + K_p·θ = −K_p·e_sensor + τ_d:
    the true angle follows minus the sensor's error through :func:`tracking_response`,
    H(s) = ω_n² / (s² + 2ζω_n·s + ω_n²), and a disturbance torque comes through as τ_d / (J·(ω_n² − ω²)).
    (For ζ = 1/√2 the −3 dB bandwidth of H is ω_n exactly.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np


@dataclass(frozen=True)
class RigidBody:
    """A rigid body with a diagonal inertia on a circular orbit.

    Args:
        inertia_kg_m2: principal moments (J_x, J_y, J_z) about the body axes, kg·m², each > 0.
        mean_motion_rad_s: the orbit's mean motion n, rad/s (≥ 0; 0: an inertially fixed "orbital" frame).
        gravity_gradient: include the gravity-gradient torque 3n²·(ẑ × J·ẑ).
    """

    inertia_kg_m2: tuple
    mean_motion_rad_s: float
    gravity_gradient: bool = True

    def __post_init__(self) -> None:
        inertia = tuple(float(j) for j in self.inertia_kg_m2)
        if len(inertia) != 3 or not all(math.isfinite(j) and j > 0.0 for j in inertia):
            raise ValueError(f"inertia_kg_m2 = {list(self.inertia_kg_m2)} must be three positive moments, kg·m²")
        jx, jy, jz = inertia
        if jx > jy + jz or jy > jx + jz or jz > jx + jy:  # the triangle inequality of any real body
            raise ValueError(f"inertia_kg_m2 = {list(inertia)} is no rigid body's: each principal moment must be "
                             "at most the sum of the other two")
        if not (math.isfinite(self.mean_motion_rad_s) and self.mean_motion_rad_s >= 0.0):
            raise ValueError(f"mean_motion_rad_s = {self.mean_motion_rad_s} must be a finite rate ≥ 0")
        object.__setattr__(self, "inertia_kg_m2", inertia)
        object.__setattr__(self, "mean_motion_rad_s", float(self.mean_motion_rad_s))

    def derivatives(self, q, rate, torque):
        """(q̇, d(rate)/dt) of the module's equations: components as given (floats or arrays).

        Args:
            q: ``(4[, N])`` attitude in the orbital frame (x, y, z, w), unit.
            rate: ``(3[, N])`` angular velocity relative to the orbital frame, body axes, rad/s.
            torque: ``(3[, N])`` external torque besides gravity gradient (control + disturbance), body axes, N·m.
        """
        x, y, z, w = q
        p, r, s = rate  # rate components about body X, Y, Z
        jx, jy, jz = self.inertia_kg_m2
        n = self.mean_motion_rad_s
        # The orbital frame's rate in body axes: n × (second row of R), R the body-to-orbital rotation.
        ox = n * 2.0 * (x * y + w * z)
        oy = n * (1.0 - 2.0 * (x * x + z * z))
        oz = n * 2.0 * (y * z - w * x)
        wx, wy, wz = p + ox, r + oy, s + oz  # the inertial rate
        hx, hy, hz = jx * wx, jy * wy, jz * wz
        tx, ty, tz = torque
        tx = tx - (wy * hz - wz * hy)
        ty = ty - (wz * hx - wx * hz)
        tz = tz - (wx * hy - wy * hx)
        if self.gravity_gradient and n > 0.0:
            # The zenith in body axes: the third row of R.
            zx = 2.0 * (x * z - w * y)
            zy = 2.0 * (y * z + w * x)
            zz = 1.0 - 2.0 * (x * x + y * y)
            gain = 3.0 * n * n
            tx = tx + gain * (jz - jy) * zy * zz
            ty = ty + gain * (jx - jz) * zz * zx
            tz = tz + gain * (jy - jx) * zx * zy
        rate_dot = (tx / jx + (r * oz - s * oy), ty / jy + (s * ox - p * oz), tz / jz + (p * oy - r * ox))
        q_dot = (0.5 * (w * p + y * s - z * r), 0.5 * (w * r + z * p - x * s), 0.5 * (w * s + x * r - y * p),
                 -0.5 * (x * p + y * r + z * s))
        return q_dot, rate_dot

    def step(self, q, rate, torque, dt_s: float):
        """One Runge–Kutta step of ``dt_s`` seconds with ``torque`` held: (q, rate) at its end, q normalised.

        Args as :meth:`derivatives`; ``dt_s`` > 0. Returns tuples of components (floats or arrays, as given).
        """
        # Component by component, no comprehension: the closed loop takes one step per sensor sample, where the
        # loops' set-up cost as much as the arithmetic (the operations and their order are the same).
        half = 0.5 * dt_s
        x, y, z, w = q
        p, r, s = rate
        (k1x, k1y, k1z, k1w), (k1p, k1r, k1s) = self.derivatives(q, rate, torque)
        (k2x, k2y, k2z, k2w), (k2p, k2r, k2s) = self.derivatives(
            (x + half * k1x, y + half * k1y, z + half * k1z, w + half * k1w),
            (p + half * k1p, r + half * k1r, s + half * k1s), torque)
        (k3x, k3y, k3z, k3w), (k3p, k3r, k3s) = self.derivatives(
            (x + half * k2x, y + half * k2y, z + half * k2z, w + half * k2w),
            (p + half * k2p, r + half * k2r, s + half * k2s), torque)
        (k4x, k4y, k4z, k4w), (k4p, k4r, k4s) = self.derivatives(
            (x + dt_s * k3x, y + dt_s * k3y, z + dt_s * k3z, w + dt_s * k3w),
            (p + dt_s * k3p, r + dt_s * k3r, s + dt_s * k3s), torque)
        sixth = dt_s / 6.0
        x = x + sixth * (k1x + 2.0 * (k2x + k3x) + k4x)
        y = y + sixth * (k1y + 2.0 * (k2y + k3y) + k4y)
        z = z + sixth * (k1z + 2.0 * (k2z + k3z) + k4z)
        w = w + sixth * (k1w + 2.0 * (k2w + k3w) + k4w)
        rate_end = (p + sixth * (k1p + 2.0 * (k2p + k3p) + k4p), r + sixth * (k1r + 2.0 * (k2r + k3r) + k4r),
                    s + sixth * (k1s + 2.0 * (k2s + k3s) + k4s))
        norm = (x * x + y * y + z * z + w * w) ** 0.5
        return (x / norm, y / norm, z / norm, w / norm), rate_end


@dataclass(frozen=True)
class PdGains:
    """Per-axis PD gains of a loop closed at ``bandwidth_hz`` with ``damping_ratio`` on ``inertia_kg_m2``.

    K_p = J·ω_n² (N·m/rad), K_d = 2ζ·J·ω_n (N·m·s/rad), ω_n = 2π·bandwidth_hz: each axis then responds as
    the second-order system of :func:`tracking_response`.
    """

    bandwidth_hz: float
    damping_ratio: float
    inertia_kg_m2: tuple

    def __post_init__(self) -> None:
        if not (math.isfinite(self.bandwidth_hz) and self.bandwidth_hz > 0.0):
            raise ValueError(f"bandwidth_hz = {self.bandwidth_hz} must be a positive frequency, Hz")
        if not (math.isfinite(self.damping_ratio) and self.damping_ratio > 0.0):
            raise ValueError(f"damping_ratio = {self.damping_ratio} must be positive")
        object.__setattr__(self, "inertia_kg_m2", tuple(float(j) for j in self.inertia_kg_m2))

    @property
    def natural_frequency_rad_s(self) -> float:
        """ω_n = 2π·bandwidth, rad/s."""
        return 2.0 * math.pi * self.bandwidth_hz

    @cached_property
    def proportional(self) -> tuple:
        """K_p per axis, N·m/rad."""
        wn2 = self.natural_frequency_rad_s ** 2
        return tuple(j * wn2 for j in self.inertia_kg_m2)

    @cached_property
    def derivative(self) -> tuple:
        """K_d per axis, N·m·s/rad."""
        gain = 2.0 * self.damping_ratio * self.natural_frequency_rad_s
        return tuple(j * gain for j in self.inertia_kg_m2)


def pd_torque(gains: PdGains, error, rate):
    """τ = −K_p·e − K_d·rate per axis, N·m: ``error`` ``(3[, N])`` (roll, pitch, yaw errors, rad; an axis that
    is not controlled passes 0 with its rate 0), ``rate`` ``(3[, N])`` body rate relative to the orbital
    frame, rad/s. Components as given (floats or arrays)."""
    (kp_x, kp_y, kp_z), (kd_x, kd_y, kd_z) = gains.proportional, gains.derivative
    return -kp_x * error[0] - kd_x * rate[0], -kp_y * error[1] - kd_y * rate[1], -kp_z * error[2] - kd_z * rate[2]


def tracking_response(omega_rad_s, bandwidth_hz: float, damping_ratio: float):
    """H(jω) = ω_n² / (ω_n² − ω² + 2jζω_n·ω): how the true angle follows minus the sensor's error at angular
    frequency ``omega_rad_s`` (complex, shaped like it); 1 − H is the tracking lag the tests allow for."""
    wn = 2.0 * math.pi * bandwidth_hz
    omega = np.asarray(omega_rad_s, float)
    return wn * wn / (wn * wn - omega * omega + 2j * damping_ratio * wn * omega)


def settling_time_s(bandwidth_hz: float, damping_ratio: float) -> float:
    """Time for a step's transient to fall to ≈ 2 % (4 time constants of the slowest pole), s."""
    wn = 2.0 * math.pi * bandwidth_hz
    zeta = damping_ratio
    slowest = zeta * wn if zeta < 1.0 else wn * (zeta - math.sqrt(zeta * zeta - 1.0))
    return 4.0 / slowest
