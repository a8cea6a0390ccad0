"""Why a difference image a - b shows the phantom's edge: a small shift or gain change
between two acquisitions, fitted to the difference.

For a smooth image m = (a + b) / 2, a shift of b by (dr, dc) pixels and a gain change g give,
to first order, a - b = -g m + dr dm/drow + dc dm/dcol + noise. A least-squares fit of these
three terms (and a constant) over the slice gives the shift and gain; at the phantom's edge
the gradient is steep, so a shift of a few hundredths of a pixel makes a bright or dark ring
(a dipole: one side positive, the opposite side negative), while noise has no such pattern.
Gibbs ringing is the same in both images and cancels in a - b, except that it carries the
shifted edge into the ripples next to it.

A shift along the readout direction of a few hundredths of a pixel is what a drift of the
resonance frequency of a few Hz does (shift = drift / pixel bandwidth).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class DifferenceModel:
    """Shift of b relative to a (rows, cols; pixels), relative gain of b over a (b = (1 +
    gain) a), and the RMS of a - b on the phantom's edge before and after removing them
    (pixel units), with the RMS inside the phantom for comparison."""

    shift_row_px: float
    shift_col_px: float
    gain: float
    edge_rms: float
    edge_rms_after: float
    interior_rms: float


#: Slices at least this many pixels on each side are fitted on their 2 x 2 means (a quarter
#: of the work; the shift limit of the checks is 0.3 px, and the fit of a 128 x 128 image
#: reads shifts to a few hundredths of a pixel).
BIN_FROM_PX = 256


def _binned(image: np.ndarray) -> np.ndarray:
    """2 x 2 means of a 2-D image (an odd last row or column dropped), float64."""
    even = image[: image.shape[0] // 2 * 2, : image.shape[1] // 2 * 2]
    out = np.add(even[0::2, 0::2], even[1::2, 0::2], dtype=np.float64)
    out += even[0::2, 1::2]
    out += even[1::2, 1::2]
    out *= 0.25
    return out


def _gradient(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """np.gradient of a 2-D float64 image (unit spacing: central differences inside,
    one-sided ones at the edges), the same numbers written straight into the two outputs (no
    temporaries)."""
    grads = []
    for axis in (0, 1):
        f = np.moveaxis(image, axis, 0)
        out = np.empty_like(image)
        g = np.moveaxis(out, axis, 0)
        np.subtract(f[2:], f[:-2], out=g[1:-1])
        g[1:-1] /= 2.0
        np.subtract(f[1], f[0], out=g[0])
        np.subtract(f[-1], f[-2], out=g[-1])
        grads.append(out)
    return grads[0], grads[1]


def shift_and_gain(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float, float]:
    """The least-squares (gain, shift rows, shift cols, offset) of a - b = -gain m + dr dm/drow
    + dc dm/dcol + offset over one 2-D slice (m = (a + b) / 2; see the module; shifts in
    pixels), from the 4 x 4 normal equations: ten sums of products over the slice (einsum: no
    BLAS threads), no N x 4 design matrix. Slices of BIN_FROM_PX or more are fitted on their
    2 x 2 means; a first-order fit reads shifts of a pixel or more only roughly (3 px as
    3.6)."""
    if min(a.shape) >= BIN_FROM_PX:
        gain, dr, dc, offset = shift_and_gain(_binned(a), _binned(b))
        return gain, 2 * dr, 2 * dc, offset
    # four slice-sized arrays at most (fresh memory costs a page fault per 4 kB): the mean's
    # column -m enters by its sign (the sums of -m are those of m negated, to the bit)
    mean = np.add(a, b, dtype=np.float64)
    mean /= 2
    diff = np.subtract(a, b, dtype=np.float64)
    del a, b  # the binned copies go here
    columns, signs = (mean, *_gradient(mean)), (-1.0, 1.0, 1.0)
    gram = np.empty((4, 4))
    rhs = np.empty(4)
    for i, x in enumerate(columns):
        for j in range(i, 3):
            gram[i, j] = gram[j, i] = signs[i] * signs[j] * np.einsum("ij,ij->", x, columns[j])
        gram[i, 3] = gram[3, i] = signs[i] * x.sum()
        rhs[i] = signs[i] * np.einsum("ij,ij->", x, diff)
    gram[3, 3], rhs[3] = mean.size, diff.sum()
    if not (np.isfinite(gram).all() and np.isfinite(rhs).all()):
        return (math.nan,) * 4  # pixels near 1e154 overflow the sums: nothing to fit
    # float64 absorbs the squared condition number of four columns; lstsq for a singular one
    return tuple(float(v) for v in np.linalg.lstsq(gram, rhs, rcond=None)[0])


def fit_difference(a: np.ndarray, b: np.ndarray, phantom: np.ndarray) -> DifferenceModel:
    """Fit shift and gain to a - b of one 2-D slice (:func:`shift_and_gain`) and measure the
    edge's RMS before and after removing them; ``phantom`` is the filled mask (the edge is the
    2 px band on each side of its border)."""
    from scipy import ndimage

    gain, dr, dc, offset = shift_and_gain(a, b)
    a, b = a.astype(np.float64), b.astype(np.float64)
    mean = (a + b) / 2
    grad_r, grad_c = _gradient(mean)
    d = a - b
    residual = d - (-gain * mean + dr * grad_r + dc * grad_c + offset)
    edge = ndimage.binary_dilation(phantom, iterations=2) & ~ndimage.binary_erosion(phantom, iterations=2)
    inner = ndimage.binary_erosion(phantom, iterations=10)
    return DifferenceModel(dr, dc, gain, float(np.sqrt(np.mean(d[edge] ** 2))),
                           float(np.sqrt(np.mean(residual[edge] ** 2))),
                           float(np.std(d[inner])))
