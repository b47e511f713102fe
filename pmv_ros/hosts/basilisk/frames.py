"""Basilisk's attitude and frames in pmv_ros's terms, and back: numpy and scipy only.

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
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ...physics.attitude import quaternion_from_roll_pitch_yaw
from ...physics.orbit.two_body import orbital_frame_from_state

#: ``dcm_CB`` for a body that Basilisk's ``hillPoint`` holds on its Hill frame: the PMV looks along −B1 (nadir),
#: its X chord along B2 (the track), its Y chord along B3 (the orbit normal); on the Hill frame it reads 0, 0.
DCM_CB_HILL = np.array([[0.0, 1.0, 0.0],
                        [0.0, 0.0, 1.0],
                        [1.0, 0.0, 0.0]])


def check_dcm(dcm, name: str = "dcm_CB") -> np.ndarray:
    """``dcm`` as a ``(3, 3)`` proper rotation matrix (orthonormal to 1e-9, determinant +1); ValueError if not."""
    matrix = np.asarray(dcm, float)
    if matrix.shape != (3, 3) or not np.all(np.isfinite(matrix)):
        raise ValueError(f"{name} must be a finite 3 x 3 direction cosine matrix, got shape {matrix.shape}")
    if not (np.allclose(matrix @ matrix.T, np.eye(3), atol=1e-9) and np.linalg.det(matrix) > 0.0):
        raise ValueError(f"{name} is not a rotation (orthonormal, determinant +1): {matrix.tolist()}")
    return matrix


def _rotation_nb(sigma_BN) -> Rotation:
    """The rotation whose matrix is ``[NB]`` (B's axes in N components) from MRPs ``(N, 3)``."""
    sigma = np.asarray(sigma_BN, float).reshape(-1, 3)
    s2 = np.sum(sigma * sigma, axis=1, keepdims=True)
    # The Euler parameters of [BN]: beta_0 = (1 - s²)/(1 + s²), beta_i = 2 sigma_i/(1 + s²); as the active
    # rotation [NB] they are the quaternion (beta_1, beta_2, beta_3, beta_0).
    return Rotation.from_quat(np.hstack([2.0 * sigma, 1.0 - s2]) / (1.0 + s2))


def attitude_in_orbital(r_BN_N, v_BN_N, sigma_BN, dcm_CB=np.eye(3)) -> np.ndarray:
    """The case frame's attitude in the orbital frame of the state, ``(4, N)`` (x, y, z, w): what the instrument
    measures (``q_orbital_to_body``), from Basilisk's ``r_BN_N``, ``v_BN_N`` and ``sigma_BN``, each ``(N, 3)``
    or ``(3,)``."""
    r = np.asarray(r_BN_N, float).reshape(-1, 3)
    v = np.asarray(v_BN_N, float).reshape(-1, 3)
    frame_no = orbital_frame_from_state(r.T, v.T)  # (3, 3, N): O's axes in N components
    rotation_no = Rotation.from_matrix(np.moveaxis(frame_no, -1, 0))
    rotation_bc = Rotation.from_matrix(np.asarray(dcm_CB, float).T)
    return (rotation_no.inv() * _rotation_nb(sigma_BN) * rotation_bc).as_quat().T


def sigma_from_roll_pitch_yaw(roll_rad, pitch_rad, yaw_rad, r_BN_N, v_BN_N, dcm_CB=np.eye(3)) -> np.ndarray:
    """Basilisk's ``sigma_BN`` ``(N, 3)`` (the short set, |σ| ≤ 1) of a body whose case frame has roll, pitch and
    yaw (REP-103, rad) in the orbital frame of the state: the inverse of :func:`attitude_in_orbital`."""
    r = np.asarray(r_BN_N, float).reshape(-1, 3)
    v = np.asarray(v_BN_N, float).reshape(-1, 3)
    rotation_no = Rotation.from_matrix(np.moveaxis(orbital_frame_from_state(r.T, v.T), -1, 0))
    rotation_oc = Rotation.from_quat(np.asarray(quaternion_from_roll_pitch_yaw(roll_rad, pitch_rad, yaw_rad)).T)
    q_nb = (rotation_no * rotation_oc * Rotation.from_matrix(np.asarray(dcm_CB, float).T).inv()).as_quat()
    q_nb = q_nb.reshape(-1, 4)
    q_nb = np.where(q_nb[:, 3:] < 0.0, -q_nb, q_nb)  # the short rotation: |σ| ≤ 1
    return q_nb[:, :3] / (1.0 + q_nb[:, 3:])
