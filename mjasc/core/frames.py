"""Frames and angles: the one place the conventions live.

World frame ENU (x east, y north, z up); heading ψ counter-clockwise from +x (east), radians.
Body frame FLU (x forward, y port, z up). See docs/architecture.md.
"""

from __future__ import annotations

import numpy as np

WORLD_LIMIT_M = 1e6
"""Largest |coordinate| [m] of anything placed in the world (positions, waypoints, obstacles):
1,000 km from the origin. Beyond it float32 rendering and the path geometry lose metres, and a
scenario that far out is a typo; the loaders reject it (``must be ≤ 1000000.0``)."""


def wrap_angle(angle_rad):
    """Wrap angle(s) to (−π, π]. Works on scalars and arrays."""
    wrapped = np.mod(np.asarray(angle_rad, dtype=float) + np.pi, 2.0 * np.pi) - np.pi
    wrapped = np.where(wrapped == -np.pi, np.pi, wrapped)
    return float(wrapped) if np.ndim(wrapped) == 0 else wrapped


def rotation_2d(angle_rad: float) -> np.ndarray:
    """2×2 rotation matrix R(ψ) taking body-frame xy vectors to world-frame xy vectors."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s], [s, c]])


def body_to_world(vectors_body: np.ndarray, heading_rad) -> np.ndarray:
    """Rotate body-frame xy vectors (n, 2) into the world frame; heading scalar or (n,)."""
    v = np.asarray(vectors_body, dtype=float)
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def world_to_body(vectors_world: np.ndarray, heading_rad) -> np.ndarray:
    """Rotate world-frame xy vectors (n, 2) into the body frame; heading scalar or (n,)."""
    v = np.asarray(vectors_world, dtype=float)
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    return np.stack([c * v[..., 0] + s * v[..., 1], -s * v[..., 0] + c * v[..., 1]], axis=-1)
