"""A regular voxel grid and the fraction of each voxel that a closed triangle mesh fills.

The fraction is found with trimesh's ray tests: rays along +z through ``supersample`` x
``supersample`` points of each voxel column give the mesh's in/out crossings, and the length
of each voxel's z-interval that lies inside is exact; the x-y supersampling averages the
rest. Lengths in mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sensor.errors import ArtefactError

#: Default points per voxel side in x and y for :func:`occupancy` (z is exact).
SUPERSAMPLE = 3

#: Offsets of the rays from the sample points, in voxels: irrational, so that no ray runs
#: along a face or through an edge of a mesh drawn on round numbers.
_JITTER = (1e-4 * math.sqrt(2.0), 1e-4 * math.sqrt(3.0))


@dataclass(frozen=True)
class Grid:
    """A box of ``shape`` cubic voxels of side ``voxel_mm``; ``lower_mm`` is the corner of
    voxel (0, 0, 0) (the box's lowest x, y, z)."""

    lower_mm: tuple[float, float, float]
    voxel_mm: float
    shape: tuple[int, int, int]

    def centres(self, axis: int) -> np.ndarray:
        """Voxel centre coordinates (mm) along ``axis``."""
        return self.lower_mm[axis] + (np.arange(self.shape[axis]) + 0.5) * self.voxel_mm

    def edges(self, axis: int) -> np.ndarray:
        """Voxel boundary coordinates (mm) along ``axis`` (one more than the voxels)."""
        return self.lower_mm[axis] + np.arange(self.shape[axis] + 1) * self.voxel_mm

    def index(self, point_mm) -> tuple[int, int, int]:
        """Indices of the voxel that holds ``point_mm``."""
        i = np.floor((np.asarray(point_mm, float) - self.lower_mm) / self.voxel_mm).astype(int)
        return tuple(int(v) for v in np.clip(i, 0, np.array(self.shape) - 1))

    def coarsened(self, factor: int) -> Grid:
        """The grid of blocks of ``factor``^3 voxels (shape divisible by ``factor``)."""
        return Grid(self.lower_mm, self.voxel_mm * factor, tuple(n // factor for n in self.shape))


def grid_around(bounds_mm, margin_mm: float, voxel_mm: float, multiple: int = 1) -> Grid:
    """The grid covering ``bounds_mm`` ((2, 3): lowest and highest corner) plus ``margin_mm``
    on every side, each side a whole number of ``multiple`` voxels, centred on the bounds."""
    lo, hi = np.asarray(bounds_mm, float)
    size = hi - lo + 2.0 * margin_mm
    n = (np.ceil(size / (voxel_mm * multiple) - 1e-9) * multiple).astype(int)
    lower = (lo + hi) / 2.0 - n * voxel_mm / 2.0
    return Grid(tuple(float(v) for v in lower), float(voxel_mm), tuple(int(v) for v in n))


def occupancy(mesh, grid: Grid, supersample: int = SUPERSAMPLE) -> np.ndarray:
    """The fraction (0-1, float32, ``grid.shape``) of each voxel inside the closed ``mesh``.

    Raises :class:`ArtefactError` if the mesh is not watertight or a ray crosses it an odd
    number of times (the inside is then undefined)."""
    if not mesh.is_watertight:
        raise ArtefactError("mesh is not watertight: its inside is undefined")
    h, s = grid.voxel_mm, int(supersample)
    nx, ny, nz = grid.shape
    out = np.zeros((nx * ny, nz), dtype=np.float64)
    (x0, y0, _), (x1, y1, _) = mesh.bounds
    sub = (np.arange(s) + 0.5) / s
    xs = (grid.lower_mm[0] + (np.arange(nx)[:, None] + sub[None, :] + _JITTER[0]) * h).ravel()
    ys = (grid.lower_mm[1] + (np.arange(ny)[:, None] + sub[None, :] + _JITTER[1]) * h).ravel()
    ix, iy = np.nonzero((xs >= x0) & (xs <= x1))[0], np.nonzero((ys >= y0) & (ys <= y1))[0]
    if len(ix) == 0 or len(iy) == 0:
        return out.reshape(grid.shape).astype(np.float32)
    IX, IY = np.meshgrid(ix, iy, indexing="ij")
    IX, IY = IX.ravel(), IY.ravel()
    z_start = min(mesh.bounds[0, 2], grid.lower_mm[2]) - 1.0
    origins = np.column_stack([xs[IX], ys[IY], np.full(IX.size, z_start)])
    directions = np.tile([0.0, 0.0, 1.0], (IX.size, 1))
    hits, ray, _ = mesh.ray.intersects_location(origins, directions, multiple_hits=True)
    z = hits[:, 2]
    order = np.lexsort((z, ray))
    ray, z = ray[order], z[order]
    # a ray through a shared edge reports the crossing once per triangle: keep one
    keep = np.ones(len(z), bool)
    keep[1:] = (ray[1:] != ray[:-1]) | (np.diff(z) > 1e-9 * max(1.0, h))
    ray, z = ray[keep], z[keep]
    counts = np.bincount(ray, minlength=IX.size)
    if np.any(counts % 2):
        bad = int(np.flatnonzero(counts % 2)[0])
        raise ArtefactError(f"a ray at x = {origins[bad, 0]:.4f}, y = {origins[bad, 1]:.4f} mm "
                            f"crosses the mesh {counts[bad]} times: the inside is undefined")
    a, b, r = z[0::2], z[1::2], ray[0::2]
    edges = grid.edges(2)
    inside = np.clip(edges[None, :] - a[:, None], 0.0, (b - a)[:, None])  # length inside below each edge
    column = (IX[r] // s) * ny + IY[r] // s
    np.add.at(out, column, np.diff(inside, axis=1))
    return (out / (h * s * s)).reshape(grid.shape).astype(np.float32)
