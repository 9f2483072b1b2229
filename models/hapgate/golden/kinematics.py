"""Linkage kinematics of docs/design/KINEMATICS.md in numpy, vectorised over any number of poses.

q = (alpha, beta, gamma) in rad along the last axis, p = (x, y, z) in m. Two independent
forward models: `fk` (the closed form the firmware uses) and `fk_construct` (rotate the crank
axes and intersect the spherical dyads), so each can check the other and the C code.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Linkage:
    """Link lengths and signs (the firmware's hg_linkage_t)."""

    l_beta: float = 0.05   # m, arm 4 (B side)
    l_gamma: float = 0.05  # m, arm 6 (Gamma side)
    h: float = 0.0         # m, parallelogram-plane offset along n
    elbow: int = 1         # IK branch: sign of delta = phi_gamma - phi_beta


DEFAULT = Linkage()


def _split(q: ArrayLike) -> tuple[F64, F64, F64]:
    qa = np.asarray(q, dtype=np.float64)
    return qa[..., 0], qa[..., 1], qa[..., 2]


def fk(q: ArrayLike, lk: Linkage = DEFAULT) -> F64:
    """Closed-form forward kinematics."""
    a, b, g = _split(q)
    ca, sa = np.cos(a), np.sin(a)
    db = np.sqrt(np.cos(b) ** 2 + ca**2 * np.sin(b) ** 2)
    dg = np.sqrt(np.cos(g) ** 2 + ca**2 * np.sin(g) ** 2)
    rho = lk.l_beta * np.cos(b) / db + lk.l_gamma * np.cos(g) / dg
    zeta = ca * (-lk.l_beta * np.sin(b) / db + lk.l_gamma * np.sin(g) / dg)
    return np.stack([lk.h * ca - rho * sa, lk.h * sa + rho * ca, zeta], axis=-1)


def _rotate(v: F64, axis: F64, ang: F64) -> F64:
    """Rodrigues: rotate the fixed vector v about the fixed unit axis by each angle."""
    c, s = np.cos(ang)[..., None], np.sin(ang)[..., None]
    return v * c + np.cross(axis, v) * s + axis * np.dot(axis, v) * (1.0 - c)


def fk_construct(q: ArrayLike, lk: Linkage = DEFAULT) -> F64:
    """Forward kinematics built from the mechanism: the A crank turns the joint axis n
    (x at q = 0) about z; the B crank (shaft on -x) and the Gamma crank (shaft on +x) turn
    their 90-degree links' distal axes w (z at q = 0). Each arm axis is the point on the unit
    sphere 90 degrees from both w and n (the intersection of two great circles), taken on the
    +y side of the A axis (the assembly branch); the endpoint is l_beta a_B + l_gamma a_G + h n.
    """
    a, b, g = _split(q)
    ex, ez = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    n = _rotate(ex, ez, a)
    u = _rotate(np.array([0.0, 1.0, 0.0]), ez, a)  # in-plane direction away from the A axis
    arms = []
    for w in (_rotate(ez, -ex, b), _rotate(ez, ex, g)):
        c = np.cross(w, n)
        c /= np.linalg.norm(c, axis=-1, keepdims=True)
        arms.append(np.where(np.sum(c * u, axis=-1, keepdims=True) < 0, -c, c))
    return lk.l_beta * arms[0] + lk.l_gamma * arms[1] + lk.h * n


def jacobian(q: ArrayLike, lk: Linkage = DEFAULT) -> F64:
    """Analytic J[..., i, j] = dp_i / dq_j (KINEMATICS.md)."""
    a, b, g = _split(q)
    ca, sa, cb, sb, cg, sg = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(g), np.sin(g)
    kb = lk.l_beta / np.sqrt(cb**2 + ca**2 * sb**2) ** 3
    kg = lk.l_gamma / np.sqrt(cg**2 + ca**2 * sg**2) ** 3
    d_a = (kb[..., None] * np.stack([-ca * cb, -sa * cb**3, sa * sb * cb**2], -1)
           + kg[..., None] * np.stack([-ca * cg, -sa * cg**3, -sa * sg * cg**2], -1)
           + lk.h * np.stack([-sa, ca, np.zeros_like(a)], -1))
    d_b = (kb * ca)[..., None] * np.stack([sa * ca * sb, -ca**2 * sb, -cb], -1)
    d_g = (kg * ca)[..., None] * np.stack([sa * ca * sg, -ca**2 * sg, cg], -1)
    return np.stack([d_a, d_b, d_g], axis=-1)


def ik(p: ArrayLike, lk: Linkage = DEFAULT) -> tuple[F64, NDArray[np.bool_]]:
    """Inverse kinematics on the branch cos(alpha) > 0, rho > 0. Returns (q, reachable)."""
    pa = np.asarray(p, dtype=np.float64)
    x, y, z = pa[..., 0], pa[..., 1], pa[..., 2]
    rr = x**2 + y**2 - lk.h**2
    rho = np.sqrt(np.maximum(rr, 0.0))
    alpha = np.arctan2(lk.h * y - rho * x, lk.h * x + rho * y)
    c = (rr + z**2 - lk.l_beta**2 - lk.l_gamma**2) / (2 * lk.l_beta * lk.l_gamma)
    ok = (rr > 0) & (np.abs(c) <= 1) & (np.cos(alpha) > 0)
    delta = lk.elbow * np.arccos(np.clip(c, -1.0, 1.0))
    phib = np.arctan2(z, rho) - np.arctan2(lk.l_gamma * np.sin(delta),
                                            lk.l_beta + lk.l_gamma * np.cos(delta))
    phig = phib + delta
    ca = np.cos(alpha)
    q = np.stack([alpha,
                  np.arctan2(-ca * np.sin(phib), ca**2 * np.cos(phib)),
                  np.arctan2(ca * np.sin(phig), ca**2 * np.cos(phig))], axis=-1)
    return q, ok


def guard(q: ArrayLike, lk: Linkage = DEFAULT, cos_alpha: float = 0.15, sin_bg: float = 0.1,
          rho: float = 0.005) -> F64:
    """The firmware's singularity fade: 1 at or above each threshold, 0 at half of it."""
    a, b, g = _split(q)
    p = fk(q, lk)
    r = np.hypot(p[..., 0], p[..., 1]) if lk.h == 0 else np.sqrt(
        np.maximum(p[..., 0] ** 2 + p[..., 1] ** 2 - lk.h**2, 0.0))

    def fade(m: F64, thr: float) -> F64:
        return np.clip(2 * m / thr - 1, 0.0, 1.0)

    return (fade(np.abs(np.cos(a)), cos_alpha) * fade(np.abs(np.sin(b + g)), sin_bg)
            * fade(r, rho))
