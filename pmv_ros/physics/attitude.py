"""Body attitude relative to the orbital frame — and THE roll/pitch sign convention (REP-103).

This is the one module that says what roll, pitch and yaw mean. The geometry,
the signal chain, the nodes, the monitor and the campaign all go through it;
the published tables' (paper) convention exists only at the edge, through
:func:`pmv_ros.physics.conventions.convert`.

Frames
    Orbital frame O: Z along the geocentric radius away from the Earth, X in
    the orbit plane towards the velocity, Y = Z × X (interfaces.md). Body
    frame B = sensor frame: boresight along −Z_B, chords along ±X_B, ±Y_B.

Convention (REP-103, tf2's roll/pitch/yaw; physics.md "Sign conventions")
    The body's axes in the orbital frame are the columns of

        R = R_z(yaw) · R_y(pitch) · R_x(roll),   v_O = R · v_B,

    R_k(α) the right-hand rotation about axis k. A body turned by +1° about
    the orbital +X reads roll = +1°, about +Y pitch = +1°. The local nadir in
    the body frame is Rᵀ·(0, 0, −1) = (sin θ, −sin φ cos θ, −cos φ cos θ)
    whatever the yaw, so a horizon sensor reads roll and pitch exactly
    (:func:`roll_pitch_from_nadir`), and yaw not at all. The published tables
    (the Kondor oblateness table, flight telemetry) have both signs reversed.

Quaternions
    ``q_orbital_to_body`` is the orientation of B in O: its rotation matrix is
    R, mapping body-frame vectors to orbital-frame components (the ROS
    convention for a child frame in its parent). Stored (x, y, z, w), the
    field order of ``geometry_msgs/Quaternion``. Arrays are ``(4,)`` or
    ``(4, N)``.
"""

from __future__ import annotations

import math

import numpy as np

#: The local nadir in the orbital frame.
NADIR_ORBITAL = np.array([0.0, 0.0, -1.0])


def _rotation_type():
    """scipy's ``Rotation``, imported at its first use: scipy.spatial costs ≈ 0.2 s of every process that imports
    this module (every node, every ``pmv`` command) and many never call what needs it."""
    from scipy.spatial.transform import Rotation

    return Rotation


def _rotation(q_xyzw):
    q = np.asarray(q_xyzw, float)
    return _rotation_type().from_quat(q.T)


def quaternion_from_roll_pitch_yaw(roll_rad, pitch_rad, yaw_rad=0.0):
    """Orientation of the body in the orbital frame, (x, y, z, w), from roll, pitch, yaw in rad.

    Scalars give ``(4,)``; arrays of N give ``(4, N)``.
    """
    roll, pitch, yaw = np.broadcast_arrays(*(np.asarray(a, float) for a in (roll_rad, pitch_rad, yaw_rad)))
    # R = R_z(ψ) R_y(θ) R_x(φ) (scipy's intrinsic Z-Y-X): the product q_z(ψ)·q_y(θ)·q_x(φ) of the three
    # half-angle quaternions, written out (scipy's from_euler composes the same three, at ≈ 1 µs a sample).
    cr, sr = np.cos(0.5 * roll), np.sin(0.5 * roll)
    cp, sp = np.cos(0.5 * pitch), np.sin(0.5 * pitch)
    cy, sy = np.cos(0.5 * yaw), np.sin(0.5 * yaw)
    return np.array([sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy,
                     cr * cp * sy - sr * sp * cy,
                     cr * cp * cy + sr * sp * sy])


def roll_pitch_yaw_from_quaternion(q_orbital_to_body):
    """Inverse of :func:`quaternion_from_roll_pitch_yaw`: (roll, pitch, yaw), rad."""
    yaw, pitch, roll = _rotation(q_orbital_to_body).as_euler("ZYX").T
    return roll, pitch, yaw


def body_axes_in_orbital(q_orbital_to_body):
    """Rotation matrix R (columns = body X, Y, Z in orbital components), ``(3, 3[, N])``."""
    matrices = _rotation(q_orbital_to_body).as_matrix()
    return np.moveaxis(matrices, 0, -1) if matrices.ndim == 3 else matrices


def nadir_in_body(q_orbital_to_body):
    """The true local nadir in the body (sensor) frame, unit ``(3[, N])``."""
    return np.einsum("ji...,j->i...", body_axes_in_orbital(q_orbital_to_body), NADIR_ORBITAL)


def roll_pitch_from_nadir(nadir_sensor):
    """Roll and pitch (REP-103), rad, that a horizon sensor reads from the nadir direction in its frame.

    The inverse of Rᵀ·(0, 0, −1) = (sin θ, −sin φ cos θ, −cos φ cos θ),
    exact for any yaw (which the nadir does not show).

    Args:
        nadir_sensor: ``(3[, ...])`` nadir direction in the sensor frame (any length).
    """
    n = np.asarray(nadir_sensor, float)
    roll = np.arctan2(-n[1], -n[2])
    pitch = np.arctan2(n[0], np.hypot(n[1], n[2]))
    return roll, pitch


def true_roll_pitch(q_orbital_to_body):
    """Roll and pitch an ideal sensor would read for this attitude (the truth to compare against), rad.

    One quaternion gives two floats, computed without building a rotation (the
    monitor converts every star-tracker sample); arrays ``(4, N)`` give arrays.
    """
    q = np.asarray(q_orbital_to_body, float)
    if q.shape == (4,):
        norm = math.sqrt(float(q @ q))
        if not (math.isfinite(norm) and norm > 0.0):
            raise ValueError(f"quaternion {q.tolist()} has no direction (zero or non-finite norm)")
        x, y, z, w = (c / norm for c in q.tolist())  # float by float: the same quotients as numpy's q / norm
        # Nadir in the body frame: −(third row of the body-axes matrix R).
        n0, n1, n2 = -2.0 * (x * z - w * y), -2.0 * (y * z + w * x), -(1.0 - 2.0 * (x * x + y * y))
        return math.atan2(-n1, -n2), math.atan2(n0, math.hypot(n1, n2))
    return roll_pitch_from_nadir(nadir_in_body(q))


def true_yaw(q_orbital_to_body):
    """Yaw (REP-103, the angle a horizon sensor cannot see), rad, of a unit quaternion (x, y, z, w).

    ψ = atan2(R[1, 0], R[0, 0]) of R = R_z(ψ)·R_y(θ)·R_x(φ); components as given: a tuple of floats gives a
    float (no rotation object built: a controller takes it every step), an array ``(4, N)`` an array.
    """
    x, y, z, w = q_orbital_to_body
    yaw = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return float(yaw) if np.ndim(yaw) == 0 else yaw


# ------------------------------------------------- quaternion algebra for one frame at a time
#
# scipy's Rotation is the reference (tests pin these functions to it), but it
# costs some 15 µs per object, and the star tracker handles one 2 Hz frame at
# a time in fast time, where a frame built from Rotation objects took 0.4 ms.
# (x, y, z, w) along axis 0: a tuple of floats is one quaternion, computed in
# plain floats and returned as a tuple; arrays (4,) or (4, N) give arrays.

#: Below this rotation angle (rad) the series of sin(θ/2)/θ is used (as scipy does).
_SMALL_ANGLE_RAD = 1e-3


def quaternion_product(a, b):
    """Hamilton product a ⊗ b of (x, y, z, w) quaternions: rotation b, then a
    (scipy's ``Rotation(a) * Rotation(b)``)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    product = (aw * bx + ax * bw + ay * bz - az * by,
               aw * by - ax * bz + ay * bw + az * bx,
               aw * bz + ax * by - ay * bx + az * bw,
               aw * bw - ax * bx - ay * by - az * bz)
    return product if isinstance(a, tuple) and isinstance(b, tuple) else np.array(product)


def quaternion_conjugate(q):
    """(−x, −y, −z, w): the inverse of a unit quaternion."""
    x, y, z, w = q
    return (-x, -y, -z, w) if isinstance(q, tuple) else np.array([-x, -y, -z, w])


def quaternion_from_rotation_vector(rotation_vector):
    """Unit quaternion (x, y, z, w) of the rotation by |v| rad about v; ``(3,)`` → ``(4,)``, ``(3, N)`` → ``(4, N)``."""
    if isinstance(rotation_vector, tuple):
        x, y, z = rotation_vector
        angle = math.sqrt(x * x + y * y + z * z)
        scale = (math.sin(0.5 * angle) / angle if angle > _SMALL_ANGLE_RAD
                 else 0.5 - angle ** 2 / 48.0 + angle ** 4 / 3840.0)
        return (x * scale, y * scale, z * scale, math.cos(0.5 * angle))
    v = np.asarray(rotation_vector, float)
    angle = np.sqrt((v * v).sum(axis=0))
    small = angle <= _SMALL_ANGLE_RAD
    scale = np.where(small, 0.5 - angle ** 2 / 48.0 + angle ** 4 / 3840.0,
                     np.sin(0.5 * angle) / np.where(small, 1.0, angle))
    return np.concatenate([v * scale, np.cos(0.5 * angle)[None]])


def rotation_vector_from_quaternion(q):
    """Rotation vector (axis × angle, rad, angle ≤ π) of a unit quaternion (x, y, z, w); ``(4[, N])`` → ``(3[, N])``."""
    if isinstance(q, tuple):
        x, y, z, w = q
        if w < 0.0:  # q and −q are the same rotation: take the one with angle ≤ π
            x, y, z, w = -x, -y, -z, -w
        angle = 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), w)
        scale = (angle / math.sin(0.5 * angle) if angle > _SMALL_ANGLE_RAD
                 else 2.0 + angle ** 2 / 12.0 + 7.0 * angle ** 4 / 2880.0)
        return (x * scale, y * scale, z * scale)
    q = np.asarray(q, float)
    q = np.where(q[3] < 0.0, -q, q)
    angle = 2.0 * np.arctan2(np.sqrt((q[:3] * q[:3]).sum(axis=0)), q[3])
    small = angle <= _SMALL_ANGLE_RAD
    scale = np.where(small, 2.0 + angle ** 2 / 12.0 + 7.0 * angle ** 4 / 2880.0,
                     angle / np.sin(0.5 * np.where(small, 1.0, angle)))
    return q[:3] * scale


def slerp(t0_s: float, q0, t1_s: float, q1, times_s):
    """Attitudes at ``times_s`` on the constant-rate turn from (t0, q0) to (t1, q1), and that turn's rate.

    The turn is taken in the orbital frame (q(t) = exp(ω (t − t0)) ⊗ q0), which
    is spherical linear interpolation. Plain floats: ``q0``, ``q1`` are
    (x, y, z, w) tuples of unit quaternions, ``times_s`` a list of floats
    (the star tracker's frame grid does the same on arrays, one turn per time:
    :func:`pmv_ros.physics.star_tracker.kernel.slerp_frames`).

    Returns:
        (list of (x, y, z, w) tuples, rate (3-tuple, rad/s, orbital components)).
    """
    dt = t1_s - t0_s
    turn = rotation_vector_from_quaternion(quaternion_product(q1, quaternion_conjugate(q0)))
    rate = tuple(w / dt for w in turn)
    frames = [quaternion_product(quaternion_from_rotation_vector(tuple((t - t0_s) * w for w in rate)), q0)
              for t in times_s]
    return frames, rate
