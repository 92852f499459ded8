"""Planar SE(2) frames of the scene and the virtual-robot spring (paper §2.2, eq. 2–10).

Poses are q = (x, y, θ) in metres and radians, y vertical (the paper's notation), θ
counter-clockwise. Functions accept a single pose (3,) or a trajectory (n, 3).
Frames: P peg centre, P1 peg top centre (where the spring attaches), P2 peg bottom centre (tip),
R robot, H hole (bottom centre of the hole).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def rotation(theta: float) -> NDArray[np.float64]:
    """R(θ), eq. 3."""
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def pose_matrix(q: ArrayLike) -> NDArray[np.float64]:
    """T ∈ SE(2) of pose q = (x, y, θ), eq. 2."""
    x, y, theta = np.asarray(q, dtype=float)
    T = np.eye(3)
    T[:2, :2] = rotation(theta)
    T[:2, 2] = (x, y)
    return T


def pose_vector(T: ArrayLike) -> NDArray[np.float64]:
    """q = f_vec(T), eq. 6."""
    T = np.asarray(T, dtype=float)
    return np.array([T[0, 2], T[1, 2], np.arctan2(T[1, 0], T[0, 0])])


def offset_along_axis(q: ArrayLike, distance_m: float) -> NDArray[np.float64]:
    """Pose of the frame ``distance_m`` along the body's own y axis: T · T(0, distance, 0), eq. 4–5.

    With q = q_P, distance l/2 gives P1 and −l/2 gives P2; from q_P1, −l gives P2.
    """
    q = np.asarray(q, dtype=float)
    theta = q[..., 2]
    out = q.copy()
    out[..., 0] = q[..., 0] - distance_m * np.sin(theta)
    out[..., 1] = q[..., 1] + distance_m * np.cos(theta)
    return out


def spring_displacement(q_robot: ArrayLike, q_peg_top: ArrayLike) -> NDArray[np.float64]:
    """δq_RP1 = q_R − q_P1, eq. 7."""
    return np.asarray(q_robot, dtype=float) - np.asarray(q_peg_top, dtype=float)


def spring_energy(q_robot: ArrayLike, q_peg_top: ArrayLike, stiffness: ArrayLike) -> NDArray:
    """E_RP = ½ δqᵀ K δq with K = diag(k_x, k_y, k_θ), eq. 8–9 (J)."""
    dq = spring_displacement(q_robot, q_peg_top)
    return 0.5 * np.sum(np.asarray(stiffness, dtype=float) * dq * dq, axis=-1)


def spring_force(q_robot: ArrayLike, q_peg_top: ArrayLike, stiffness: ArrayLike) -> NDArray:
    """Elastic force (F_x, F_y, moment) the robot exerts on the peg at P1, eq. 10.

    f_RP = −∇_{q_P1} E_RP = +K δq_RP1: the spring pulls the peg toward the robot frame (the paper
    prints −K δq; with δq = q_R − q_P1 the gradient of eq. 9 gives +K δq).
    """
    return np.asarray(stiffness, dtype=float) * spring_displacement(q_robot, q_peg_top)
