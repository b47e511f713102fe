"""Basilisk's attitude and frames in pmv_ros's terms, and back: compiled kernels, one path for one state or many.

Basilisk's conventions (its names carry the frames): ``sigma_BN`` the MRP of
the body frame B relative to the inertial frame N (the DCM ``[BN]`` maps
N-frame components to B-frame ones), ``r_BN_N`` and ``v_BN_N`` the
position and velocity of B relative to N in N-frame components, m and m/s.
Its Hill frame (``hillPoint``) has axis 1 along the radius, 3 along the
orbit normal, 2 = 3 × 1 along the track.

pmv_ros's (:mod:`pmv_ros.physics.attitude`): the orbital frame O has Z along
the radius away from the Earth, X along the track, Y = Z × X the orbit
normal — the Hill frame's axes 2, 3, 1; the instrument's case frame C is
pmv_ros's body frame (boresight −Z_C, chords ±X_C, ±Y_C), given in
Basilisk's body frame by ``dcm_CB`` (Basilisk's habit for a sensor's case
frame: ``[CB]`` maps B-frame components to C-frame ones); the attitude the
instrument measures is ``q_orbital_to_body`` of C in O, (x, y, z, w), whose
rotation matrix ``[OC]`` has C's axes in O components as its columns.

Basilisk's N is taken as pmv_ros's ECI (the mean equator and equinox of
date; an N of J2000 axes differs by the precession since 2000, ≈ 0.2° in
2013, which moves where the Sun, the Moon and the Earth's fields are, not
the geometry the instrument sees).

The conversions run at every step of a simulation (the sensor module, the
navigation bridge), so each is one compiled kernel
(:func:`pmv_ros.physics.compiled.kernel`) on plain floats: a state is a
3-tuple, a DCM a 9-tuple (row by row), and the array functions loop the same
kernel over their states. Formulas: Schaub & Junkins, *Analytical Mechanics of
Space Systems* — the DCM of an MRP set (eq. 3.153), the Euler parameters of a
DCM by Sheppard's method (eqs. 3.94–3.95), the MRP of Euler parameters
(eq. 3.147); the orbital frame is the sensor's own
(:func:`pmv_ros.physics.orbit.two_body.orbital_axes`).
"""

from __future__ import annotations

import math

import numpy as np

from ...physics.compiled import kernel
from ...physics.orbit.two_body import orbital_axes

#: ``dcm_CB`` for a body that Basilisk's ``hillPoint`` holds on its Hill frame: the PMV looks along −B1 (nadir),
#: its X chord along B2 (the track), its Y chord along B3 (the orbit normal); on the Hill frame it reads 0, 0.
DCM_CB_HILL = np.array([[0.0, 1.0, 0.0],
                        [0.0, 0.0, 1.0],
                        [1.0, 0.0, 0.0]])


def check_dcm(dcm, name: str = "dcm_CB") -> np.ndarray:
    """``dcm`` as a ``(3, 3)`` proper rotation matrix (orthonormal to 1e-9, determinant +1); ValueError if not."""
    try:
        matrix = np.asarray(dcm, float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 3 x 3 direction cosine matrix of numbers, got "
                         f"{type(dcm).__name__}") from None
    if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        raise ValueError(f"{name} must be a finite 3 x 3 direction cosine matrix, got shape {matrix.shape}")
    if not (np.allclose(matrix @ matrix.T, np.eye(3), atol=1e-9) and np.linalg.det(matrix) > 0.0):
        raise ValueError(f"{name} is not a rotation (orthonormal, determinant +1): {matrix.tolist()}")
    return matrix


def dcm_tuple(dcm) -> tuple:
    """A ``(3, 3)`` DCM as the kernels take it: 9 floats, row by row."""
    return tuple(float(c) for c in np.asarray(dcm, float).ravel())


_NAN4 = (math.nan, math.nan, math.nan, math.nan)


@kernel
def dcm_of_mrp(sigma):
    """``[BN]`` (9-tuple, row by row) of the MRP ``sigma`` (3-tuple) of B relative to N; all NaN if not finite.

    A set with |σ| > 1 is first replaced by its shadow set −σ/|σ|², the same rotation (Basilisk switches to
    it at |σ| = 1 too): every finite MRP, however large, is then computed without overflow.
    """
    s1, s2, s3 = sigma
    largest = max(abs(s1), abs(s2), abs(s3))
    if not largest < math.inf:  # NaN or infinite
        return (math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan)
    if largest > 0.0:
        norm = largest * math.sqrt((s1 / largest) ** 2 + (s2 / largest) ** 2 + (s3 / largest) ** 2)
        if norm > 1.0:
            s1, s2, s3 = -s1 / norm / norm, -s2 / norm / norm, -s3 / norm / norm
    squared = s1 * s1 + s2 * s2 + s3 * s3
    scale = 1.0 / ((1.0 + squared) * (1.0 + squared))
    skew = 4.0 * (1.0 - squared)
    # [BN] = I + (8 [σ̃]² − 4 (1 − σ²) [σ̃]) / (1 + σ²)², [σ̃]² = σσᵀ − σ² I
    return (1.0 + scale * 8.0 * (s1 * s1 - squared), scale * (8.0 * s1 * s2 + skew * s3),
            scale * (8.0 * s1 * s3 - skew * s2),
            scale * (8.0 * s2 * s1 - skew * s3), 1.0 + scale * 8.0 * (s2 * s2 - squared),
            scale * (8.0 * s2 * s3 + skew * s1),
            scale * (8.0 * s3 * s1 + skew * s2), scale * (8.0 * s3 * s2 - skew * s1),
            1.0 + scale * 8.0 * (s3 * s3 - squared))


@kernel
def euler_parameters(c):
    """The Euler parameters (β0, β1, β2, β3), β0 ≥ 0, of the DCM ``c`` (9-tuple, row by row), by Sheppard's
    method: the largest of the four squares first, so no division by a small number."""
    trace = c[0] + c[4] + c[8]
    squares = ((1.0 + trace) / 4.0, (1.0 + 2.0 * c[0] - trace) / 4.0, (1.0 + 2.0 * c[4] - trace) / 4.0,
               (1.0 + 2.0 * c[8] - trace) / 4.0)
    largest = 0
    for k in range(1, 4):
        if squares[k] > squares[largest]:
            largest = k
    if largest == 0:
        b0 = math.sqrt(squares[0])
        b1, b2, b3 = (c[5] - c[7]) / (4.0 * b0), (c[6] - c[2]) / (4.0 * b0), (c[1] - c[3]) / (4.0 * b0)
    elif largest == 1:
        b1 = math.sqrt(squares[1])
        b0, b2, b3 = (c[5] - c[7]) / (4.0 * b1), (c[1] + c[3]) / (4.0 * b1), (c[6] + c[2]) / (4.0 * b1)
    elif largest == 2:
        b2 = math.sqrt(squares[2])
        b0, b1, b3 = (c[6] - c[2]) / (4.0 * b2), (c[1] + c[3]) / (4.0 * b2), (c[5] + c[7]) / (4.0 * b2)
    else:
        b3 = math.sqrt(squares[3])
        b0, b1, b2 = (c[1] - c[3]) / (4.0 * b3), (c[6] + c[2]) / (4.0 * b3), (c[5] + c[7]) / (4.0 * b3)
    if b0 < 0.0:
        return -b0, -b1, -b2, -b3
    return b0, b1, b2, b3


@kernel
def _case_in_orbital(r_BN_N, v_BN_N, sigma_BN, cb):
    """``[CO]`` (9-tuple) of a state: the case frame's DCM relative to the orbital frame; NaN if undefined."""
    x_axis, y_axis, z_axis = orbital_axes(r_BN_N, v_BN_N)
    bn = dcm_of_mrp(sigma_BN)
    axes = (x_axis, y_axis, z_axis)
    co = [0.0] * 9
    for i in range(3):
        # C's axis i in N components: row i of [CN] = [CB][BN]
        c0 = cb[3 * i] * bn[0] + cb[3 * i + 1] * bn[3] + cb[3 * i + 2] * bn[6]
        c1 = cb[3 * i] * bn[1] + cb[3 * i + 1] * bn[4] + cb[3 * i + 2] * bn[7]
        c2 = cb[3 * i] * bn[2] + cb[3 * i + 1] * bn[5] + cb[3 * i + 2] * bn[8]
        for j in range(3):
            co[3 * i + j] = c0 * axes[j][0] + c1 * axes[j][1] + c2 * axes[j][2]
    return (co[0], co[1], co[2], co[3], co[4], co[5], co[6], co[7], co[8])


@kernel
def case_attitude(r_BN_N, v_BN_N, sigma_BN, cb):
    """The case frame's attitude in the orbital frame of one state, (x, y, z, w) with w ≥ 0: what the
    instrument measures. ``r_BN_N``, ``v_BN_N``, ``sigma_BN`` 3-tuples (m, m/s, MRP), ``cb`` the 9-tuple
    ``[CB]``. NaN where the MRP is not finite or the state has no orbital frame (r = 0, or no velocity
    across r)."""
    co = _case_in_orbital(r_BN_N, v_BN_N, sigma_BN, cb)
    for value in co:
        if not abs(value) < math.inf:
            return _NAN4
    # The Euler parameters of [CO] are the quaternion of the rotation [OC] = [CO]ᵀ: (β1, β2, β3, β0).
    b0, b1, b2, b3 = euler_parameters(co)
    return b1, b2, b3, b0


@kernel
def _sigma_of_case(roll_rad, pitch_rad, yaw_rad, r_BN_N, v_BN_N, cb):
    """``sigma_BN`` (short set) of a body whose case frame has roll, pitch, yaw (REP-103) in the orbital frame."""
    x_axis, y_axis, z_axis = orbital_axes(r_BN_N, v_BN_N)
    axes = (x_axis, y_axis, z_axis)
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
    # [OC] = R_z(yaw) R_y(pitch) R_x(roll) (pmv_ros.physics.attitude), row by row
    oc = (cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,
          sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,
          -sp, cp * sr, cp * cr)
    bn = [0.0] * 9
    for j in range(3):
        # [CN] column j: the N axis j in C components, (Σ_k [OC]_ki O_k[j])_i
        cn0 = oc[0] * axes[0][j] + oc[3] * axes[1][j] + oc[6] * axes[2][j]
        cn1 = oc[1] * axes[0][j] + oc[4] * axes[1][j] + oc[7] * axes[2][j]
        cn2 = oc[2] * axes[0][j] + oc[5] * axes[1][j] + oc[8] * axes[2][j]
        for i in range(3):  # [BN] = [CB]ᵀ [CN]
            bn[3 * i + j] = cb[i] * cn0 + cb[3 + i] * cn1 + cb[6 + i] * cn2
    b0, b1, b2, b3 = euler_parameters((bn[0], bn[1], bn[2], bn[3], bn[4], bn[5], bn[6], bn[7], bn[8]))
    return b1 / (1.0 + b0), b2 / (1.0 + b0), b3 / (1.0 + b0)


@kernel
def navigation_sigma(sigma_nav, r_BN_N, v_BN_N, nadir_B, cb):
    """``sigma_BN`` whose case frame has the roll and pitch the measured nadir ``nadir_B`` (3-tuple, body
    components, any length) gives and the yaw of the attitude ``sigma_nav``, both in the orbital frame of the
    state ``r_BN_N``, ``v_BN_N``. NaN where the nadir, the attitude or the orbital frame is undefined.

    Roll and pitch of the nadir n in C: n = (sin θ, −sin φ cos θ, −cos φ cos θ) whatever the yaw
    (:func:`pmv_ros.physics.attitude.roll_pitch_from_nadir`); the yaw of ``[OC] = R_z(ψ) R_y(θ) R_x(φ)`` is
    atan2([OC]₁₀, [OC]₀₀).
    """
    co = _case_in_orbital(r_BN_N, v_BN_N, sigma_nav, cb)
    yaw = math.atan2(co[1], co[0])  # [OC]₁₀ = [CO]₀₁
    n0 = cb[0] * nadir_B[0] + cb[1] * nadir_B[1] + cb[2] * nadir_B[2]
    n1 = cb[3] * nadir_B[0] + cb[4] * nadir_B[1] + cb[5] * nadir_B[2]
    n2 = cb[6] * nadir_B[0] + cb[7] * nadir_B[1] + cb[8] * nadir_B[2]
    if not (n0 * n0 + n1 * n1 + n2 * n2 > 0.0):
        return math.nan, math.nan, math.nan
    roll = math.atan2(-n1, -n2)
    pitch = math.atan2(n0, math.hypot(n1, n2))
    return _sigma_of_case(roll, pitch, yaw, r_BN_N, v_BN_N, cb)


@kernel
def nadir_in_body(roll_rad, pitch_rad, cb):
    """The nadir (unit, body components) a case frame with this roll and pitch (REP-103) in the orbital frame
    sees: [BC]·(sin θ, −sin φ cos θ, −cos φ cos θ) (:func:`pmv_ros.physics.attitude.nadir_in_body`)."""
    n0 = math.sin(pitch_rad)
    n1 = -math.sin(roll_rad) * math.cos(pitch_rad)
    n2 = -math.cos(roll_rad) * math.cos(pitch_rad)
    return (cb[0] * n0 + cb[3] * n1 + cb[6] * n2, cb[1] * n0 + cb[4] * n1 + cb[7] * n2,
            cb[2] * n0 + cb[5] * n1 + cb[8] * n2)


@kernel
def _case_attitudes(r, v, sigma, cb, out):
    for n in range(r.shape[0]):
        q = case_attitude((r[n, 0], r[n, 1], r[n, 2]), (v[n, 0], v[n, 1], v[n, 2]),
                          (sigma[n, 0], sigma[n, 1], sigma[n, 2]), cb)
        for k in range(4):
            out[k, n] = q[k]


@kernel
def _sigmas_of_case(roll, pitch, yaw, r, v, cb, out):
    for n in range(r.shape[0]):
        s = _sigma_of_case(roll[n], pitch[n], yaw[n], (r[n, 0], r[n, 1], r[n, 2]), (v[n, 0], v[n, 1], v[n, 2]), cb)
        for k in range(3):
            out[n, k] = s[k]


def _states(*vectors):
    """``(N, 3)`` float arrays of ``(N, 3)`` or ``(3,)`` inputs, broadcast to one N."""
    arrays = [np.asarray(vector, float).reshape(-1, 3) for vector in vectors]
    count = max(array.shape[0] for array in arrays)
    return [np.ascontiguousarray(np.broadcast_to(array, (count, 3))) for array in arrays]


def attitude_in_orbital(r_BN_N, v_BN_N, sigma_BN, dcm_CB=np.eye(3)) -> np.ndarray:
    """The case frame's attitude in the orbital frame of the state, ``(4, N)`` (x, y, z, w): what the instrument
    measures (``q_orbital_to_body``), from Basilisk's ``r_BN_N``, ``v_BN_N`` and ``sigma_BN``, each ``(N, 3)``
    or ``(3,)`` (:func:`case_attitude` state by state; NaN columns where it is undefined)."""
    r, v, sigma = _states(r_BN_N, v_BN_N, sigma_BN)
    out = np.empty((4, r.shape[0]))
    _case_attitudes(r, v, sigma, dcm_tuple(dcm_CB), out)
    return out


def sigma_from_roll_pitch_yaw(roll_rad, pitch_rad, yaw_rad, r_BN_N, v_BN_N, dcm_CB=np.eye(3)) -> np.ndarray:
    """Basilisk's ``sigma_BN`` ``(N, 3)`` (the short set, |σ| ≤ 1) of a body whose case frame has roll, pitch and
    yaw (REP-103, rad) in the orbital frame of the state: the inverse of :func:`attitude_in_orbital`."""
    r, v = _states(r_BN_N, v_BN_N)
    angles = np.broadcast_arrays(*(np.atleast_1d(np.asarray(a, float)) for a in (roll_rad, pitch_rad, yaw_rad)))
    count = max(r.shape[0], angles[0].size)
    r, v = (np.ascontiguousarray(np.broadcast_to(x, (count, 3))) for x in (r, v))
    roll, pitch, yaw = (np.ascontiguousarray(np.broadcast_to(a.ravel(), (count,))) for a in angles)
    out = np.empty((count, 3))
    _sigmas_of_case(roll, pitch, yaw, r, v, dcm_tuple(dcm_CB), out)
    return out
