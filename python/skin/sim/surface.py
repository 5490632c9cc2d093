"""The skin's surface as MuJoCo samples it, and the cover's kernel from the surface to the taxels.

A taxel reads the stress that reaches it through the elastic cover, and that stress comes from
the whole surface around it, not only from the point right above it: a fingertip pressing between
two taxels is felt by both. So MuJoCo samples the surface on a grid finer than the taxels (each
triangle of the skin's triangulation cut into n x n smaller ones, `spacing` apart), and each
taxel gathers the force on the samples around it through Boussinesq's point-load stress at the
cover's depth h (the elastic probe of the calibration tests):

    sigma_z(rho) = 3 h^3 / (2 pi (rho^2 + h^2)^(5/2))     per newton, integrates to 1 over the plane

cut at rho = 4 h (98.6% of it). A sample stands for its patch of surface (area A), not a point: its
weight is the kernel at sqrt(rho^2 + A / 2 pi), which is the kernel's mean over a disc of that
area to within 4% at rho = 0 (and closer beyond), so that the stress of an even load does not
hang on where a taxel falls among the samples (a taxel sits on one; the kernel's half width,
1.1 h, is about the samples' spacing).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._errors import ArrayError

#: The kernel is cut at this many cover thicknesses.
KERNEL_REACH = 4.0

#: A link's surface is sampled at no more points than this (the spacing is refused otherwise).
MAX_POINTS = 2_000_000


@dataclass(frozen=True)
class Surface:
    """Points on a link's skin surface (its frame, metres), their triangles and the area each
    point stands for (square metres)."""

    points: np.ndarray  # (M, 3)
    faces: np.ndarray  # (K, 3) int
    areas: np.ndarray  # (M,)


def sample_surface(positions: np.ndarray, faces: np.ndarray, spacing: float) -> Surface:
    """Each triangle of `faces` (indices into `positions`) cut into n x n triangles, n chosen so
    that the median edge becomes at most `spacing` long; points on shared edges appear once."""
    positions = np.asarray(positions, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
        raise ArrayError("the skin needs a triangulation: (K, 3) faces, K > 0")
    if faces.min() < 0 or faces.max() >= len(positions):
        raise ArrayError(f"faces index taxels 0 to {len(positions) - 1}; found {faces.min()} to {faces.max()}")
    edges = np.linalg.norm(positions[faces] - positions[np.roll(faces, 1, axis=1)], axis=2)
    # Cut by the longest edge of the typical triangle (the 90th percentile), so that few are
    # sampled coarser than `spacing`.
    n = max(1, int(np.ceil(np.percentile(edges.max(axis=1), 90) / spacing)))
    if len(faces) * (n + 1) * (n + 2) // 2 > MAX_POINTS:
        raise ArrayError(
            f"spacing {spacing * 1e3:g} mm cuts each of the {len(faces)} triangles into {n * n}: "
            f"more than {MAX_POINTS} points; take a coarser spacing"
        )
    # The grid of one triangle: weights (n - i - j, i, j) of its corners a, b, c.
    ij = np.array([(i, j) for i in range(n + 1) for j in range(n + 1 - i)], dtype=np.int64)
    w = np.column_stack([n - ij[:, 0] - ij[:, 1], ij[:, 0], ij[:, 1]])  # (G, 3)
    local = {(i, j): g for g, (i, j) in enumerate(ij.tolist())}
    # A point is named by its corners and their weights, whatever triangle makes it, so that a
    # point on an edge or a corner two triangles share is made once.
    corners = faces[:, None, :].repeat(len(w), axis=1)  # (K, G, 3)
    weights = np.broadcast_to(w, corners.shape)
    named = np.where(weights > 0, corners, -1)
    order = np.argsort(named, axis=2)
    key = np.concatenate(
        [np.take_along_axis(named, order, axis=2), np.take_along_axis(weights, order, axis=2)], axis=2
    ).reshape(-1, 6)
    unique, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(len(faces), len(w))
    flat_corners = corners.reshape(-1, 3)[first]
    flat_weights = weights.reshape(-1, 3)[first] / n
    points = np.einsum("mk,mkd->md", flat_weights, positions[flat_corners])
    # Each triangle's small triangles, in its grid's numbering, then in the points'.
    small = []
    for i in range(n):
        for j in range(n - i):
            small.append((local[(i, j)], local[(i + 1, j)], local[(i, j + 1)]))
            if i + j < n - 1:
                small.append((local[(i + 1, j)], local[(i + 1, j + 1)], local[(i, j + 1)]))
    small = np.array(small, dtype=np.int64)
    tris = inverse[:, small].reshape(-1, 3)
    a, b, c = points[tris[:, 0]], points[tris[:, 1]], points[tris[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    areas = np.zeros(len(points))
    for k in range(3):
        np.add.at(areas, tris[:, k], area / 3.0)
    del unique
    return Surface(points=points, faces=tris, areas=areas)


@dataclass(frozen=True)
class Kernel:
    """Per taxel, the samples within reach and the stress each newton on them gives it
    (1 / m^2): `stress = (weights * forces[index]).sum(axis=1)`, padded with weight 0."""

    index: np.ndarray  # (N, K) int
    weights: np.ndarray  # (N, K)

    def stress(self, forces: np.ndarray) -> np.ndarray:
        """Stress at each taxel (Pa) of the forces on the samples (N)."""
        return np.einsum("nk,nk->n", self.weights, forces[self.index])


def boussinesq(taxels: np.ndarray, samples: np.ndarray, cover: float, areas: np.ndarray) -> Kernel:
    """The kernel from `samples` (each standing for `areas`, m^2) to `taxels` through a cover
    `cover` metres thick."""
    taxels = np.asarray(taxels, dtype=np.float64)
    reach2 = (KERNEL_REACH * cover) ** 2
    rows: list = []
    # Blocks of taxels keep the distance matrix small whatever the skin's size.
    for start in range(0, len(taxels), 256):
        d2 = ((taxels[start : start + 256, None, :] - samples[None, :, :]) ** 2).sum(axis=2)
        for r in d2:
            near = np.flatnonzero(r <= reach2)
            rows.append((near, r[near]))
    width = max(1, max(len(near) for near, _ in rows))
    index = np.zeros((len(taxels), width), dtype=np.int64)
    weights = np.zeros((len(taxels), width))
    h3 = cover**3
    spread = areas / (2.0 * np.pi)
    for t, (near, r2) in enumerate(rows):
        index[t, : len(near)] = near
        weights[t, : len(near)] = 3.0 * h3 / (2.0 * np.pi * (r2 + spread[near] + cover**2) ** 2.5)
    return Kernel(index=index, weights=weights)
