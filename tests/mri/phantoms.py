"""Synthetic phantom slices with a known centre: discs and rectangles with strong shading,
notches, air-bubble chords and inserts, drawn with partial-volume edges (4 x 4 supersampling)
so that a fractional centre is exact."""

from __future__ import annotations

import numpy as np

SUPERSAMPLE = 4


def _grid(shape, sub=SUPERSAMPLE):
    """Supersampled pixel-centre coordinates (row, col) in pixel units."""
    offsets = (np.arange(sub) + 0.5) / sub - 0.5
    r = (np.arange(shape[0])[:, None] + offsets[None, :]).ravel()
    c = (np.arange(shape[1])[:, None] + offsets[None, :]).ravel()
    return r[:, None], c[None, :]


def _average(fine, shape, sub=SUPERSAMPLE):
    return fine.reshape(shape[0], sub, shape[1], sub).mean(axis=(1, 3))


def phantom(
    shape=(256, 256),
    centre=(121.3, 133.6),
    radius=95.0,
    kind="circle",
    half_size=(70.0, 100.0),
    signal=1000.0,
    shading=None,
    notch=None,
    chord_depth=0.0,
    inserts=(),
    background=0.0,
):
    """Noise-free phantom image.

    ``shading``: None, ("linear", low) -- brightness falls linearly from 1 to ``low`` across the
    phantom from left to right --, or ("radial", low) -- ``low`` at the centre, 1 at the edge
    (a receive array). ``notch``: (angle_deg, depth, width) of a rectangular cut into the edge
    at that angle (0 = right, 90 = up). ``chord_depth``: depth (px) of a flat air bubble cut off
    the top. ``inserts``: ((row, col, radius, relative value), ...).
    """
    r, c = _grid(shape)
    dr, dc = r - centre[0], c - centre[1]
    if kind == "circle":
        inside = dr**2 + dc**2 <= radius**2
        extent = radius
    else:
        inside = (np.abs(dr) <= half_size[0]) & (np.abs(dc) <= half_size[1])
        extent = max(half_size)
    inside = np.broadcast_to(inside, (r.size, c.size)).copy()
    value = np.ones_like(inside, dtype=float)
    if shading and shading[0] == "linear":
        value = value * (1 - (1 - shading[1]) * np.clip((dc + extent) / (2 * extent), 0, 1))
    elif shading and shading[0] == "radial":
        value = value * (shading[1] + (1 - shading[1]) * np.clip((dr**2 + dc**2) / extent**2, 0, 1))
    if notch:
        angle, depth, width = notch
        u = np.array([-np.sin(np.radians(angle)), np.cos(np.radians(angle))])  # (row, col) outward
        along = dr * u[0] + dc * u[1]
        across = -dr * u[1] + dc * u[0]
        inside &= ~((along > extent - depth) & (np.abs(across) < width / 2))
    if chord_depth:
        inside &= np.broadcast_to(dr >= -(radius - chord_depth), inside.shape)
    for row, col, rad, rel in inserts:
        value = np.where((r - row) ** 2 + (c - col) ** 2 <= rad**2, rel, value)
    return background + signal * _average(np.where(inside, value, 0.0), shape)


def noisy_pair(truth, sigma, seed, rician=True):
    """Two independent noisy acquisitions of ``truth``: magnitude (Rician) or Gaussian."""
    rng = np.random.default_rng(seed)

    def one():
        if rician:
            return np.hypot(truth + rng.normal(0, sigma, truth.shape), rng.normal(0, sigma, truth.shape))
        return truth + rng.normal(0, sigma, truth.shape)

    return one(), one()
