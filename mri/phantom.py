"""Find the phantom in one 2-D slice: a threshold robust to shading, the filled mask, and the
centre from a geometric fit of the outline (circle or axis-aligned rectangle).

Why not Otsu and the centroid (the first version, and hazen's fallback): a coil's shading
pulls Otsu's threshold into the phantom (dark parts fall out of the mask), and the centroid of
a mask moves with every notch, insert, air bubble and shaded edge. Here

* the threshold is set against the background noise, not the signal: ``AIR_SIGMAS``
  standard deviations above the mean of the air, measured in the four corner squares of the
  image (``1 / AIR_CORNER_DIVISOR`` of its smaller side); the median of the four corners'
  thresholds is taken, so one corner reaching into the phantom or a ghost does not raise it.
  Magnitude air (Rayleigh, mean 1.25 sigma, std 0.655 sigma) gives a threshold of 4.5 sigma:
  a phantom is found whole wherever its signal exceeds about 4.5 times the channel noise,
  however strong a coil's shading. The threshold is kept between ``FLOOR_FRACTION`` (a
  noiseless or zero-filled background) and ``CEILING_FRACTION`` (a very noisy image, where
  4.5 sigma would cut a shaded edge) of the range from the 1st to the 99th percentile;
* the mask is the largest connected region above it, holes (dark inserts) filled; a region
  that reaches all four image edges is no phantom (noise percolates at such a threshold);
* the outline is the outermost mask pixel of every row (left and right) and every column
  (top and bottom), moved half a pixel outwards onto the pixel edge; holes and inserts never
  reach it;
* a circle is fitted to the outline by least squares (Kasa's algebraic fit), then refitted
  without the points further than ``OUTLIER_PX`` (or 3 robust standard deviations) from it:
  notches, flat air-bubble chords and ghosts drop out; an axis-aligned rectangle is fitted by
  the median of each side's outline. The shape that fits more outline points within
  ``OUTLIER_PX`` gives the centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from mri.errors import RoiError

#: Threshold = mean + AIR_SIGMAS x std of the air in each corner square (side: the image's
#: smaller side / AIR_CORNER_DIVISOR), median over the four corners.
AIR_SIGMAS = 5.0
AIR_CORNER_DIVISOR = 8
#: Ceiling and floor of the threshold: these fractions of the way from the 1st to the 99th
#: percentile. The ceiling applies only to images whose phantom edge is within a few sigma
#: of the air (SNR below ~20); the floor only when the corners hold no noise.
CEILING_FRACTION, FLOOR_FRACTION = 0.2, 0.05
#: Percentiles taken as the background and bright levels of the floor.
BACKGROUND_PERCENTILE, BRIGHT_PERCENTILE = 1.0, 99.0
#: Outline points further than this (pixels) from a fitted shape are outliers.
OUTLIER_PX = 1.5
#: Refits of the circle after dropping outliers.
CIRCLE_REFITS = 3


@dataclass(frozen=True)
class PhantomFit:
    """The phantom found on one slice: centre (row, col) in pixels (fractional), its shape
    ("circle" or "rectangle"), size (radius, or half height and half width, pixels), the
    fraction of outline points within OUTLIER_PX of the shape, the threshold used and the
    centroid (row, col) of the filled mask (a second, cruder centre to check the fit by)."""

    centre_px: tuple[float, float]
    shape: str
    size_px: tuple[float, ...]
    inlier_fraction: float
    threshold: float
    centroid_px: tuple[float, float]


def air_threshold(image: np.ndarray) -> float:
    """Mean + AIR_SIGMAS x std of the air, pixel units: the median over the four corner
    squares of the image."""
    side = max(2, min(image.shape) // AIR_CORNER_DIVISOR)
    corners = (image[:side, :side], image[:side, -side:], image[-side:, :side], image[-side:, -side:])
    return _median(np.array([mean + AIR_SIGMAS * std for mean, std in map(_mean_std, corners)]))


def _mean_std(values: np.ndarray) -> tuple[float, float]:
    """np.mean and np.std (ddof 0) of an array in float64, the same operations as numpy's
    in the same order (the same numbers to the bit), the sum taken once for both."""
    mean = np.add.reduce(values, axis=None, dtype=np.float64) / values.size
    square = np.subtract(values, mean, dtype=np.float64)
    np.multiply(square, square, out=square)
    return float(mean), float(np.sqrt(np.add.reduce(square, axis=None, dtype=np.float64) / values.size))


def detection_threshold(image: np.ndarray) -> float:
    """The phantom's threshold (pixel units): :func:`air_threshold`, kept between
    FLOOR_FRACTION and CEILING_FRACTION of the way from the background to the bright level
    (1st, 99th percentiles, from a 1-in-4 sample of the pixels when the image is large)."""
    sample = image.ravel()[::4] if image.size >= 4096 else image.ravel()
    n = sample.size - 1
    k_lo, k_hi = int(round(n * BACKGROUND_PERCENTILE / 100)), int(round(n * BRIGHT_PERCENTILE / 100))
    # the two order statistics by two single partitions (a third of the time of one partition
    # at two positions): the k_hi-th first, then the k_lo-th among the values below it
    part = sample.copy()
    part.partition(k_hi)
    below = part[:k_hi] if k_lo < k_hi else part
    below.partition(k_lo)
    lo, hi = float(below[k_lo]), float(part[k_hi])
    if not hi > lo:
        raise RoiError("automatic phantom mask: the image is uniform, no phantom to find")
    return min(max(air_threshold(image), lo + FLOOR_FRACTION * (hi - lo)),
               lo + CEILING_FRACTION * (hi - lo))


def bounding_box(mask: np.ndarray) -> tuple[slice, slice] | None:
    """The rows and columns (slices) of the smallest box holding every True pixel of a 2-D
    boolean mask; None when there is none."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return None
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def above(image: np.ndarray, threshold: float) -> np.ndarray:
    """The pixels of ``image`` above ``threshold``, compared in float64 whatever the image's
    type (a float32 comparison would round the threshold to float32)."""
    return np.greater(image, threshold, signature="dd->?")


#: 4-connectivity, the structure ndimage.label uses by default (given: not rebuilt each call).
CROSS = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=bool)


def fill_holes(mask: np.ndarray) -> np.ndarray:
    """``mask`` with every background region that does not touch the image border filled."""
    return _filled(mask)[0]


def _filled(mask: np.ndarray):
    """:func:`fill_holes` of ``mask``, its bounding box and the :func:`_spans` of the box's
    rows and columns, from which :func:`_outline` gives the outline of ``mask`` and of the
    filled mask alike (a hole never holds a row's or a column's outermost pixel).

    A hole pixel lies between mask pixels both in its row and in its column (otherwise its row
    or column leads straight out), so in a row and a column with a gap. Candidates are looked
    for where these cross, then labelled in their bounding box (none: no hole, no labelling);
    a region of candidates is a hole unless it touches a background pixel that is no
    candidate, which is connected to the outside.
    """
    box = bounding_box(mask)
    filled = mask.copy()
    if box is None:
        return filled, None, None, None
    region = mask[box]
    row_first, row_after, row_gaps = row_spans = _spans(region)
    col_first, col_after, col_gaps = col_spans = _spans(region.T)
    gap_rows, gap_cols = np.flatnonzero(row_gaps), np.flatnonzero(col_gaps)
    hits = np.nonzero(_candidates(region, gap_rows[:, None], gap_cols, row_first, row_after,
                                  col_first, col_after))
    if hits[0].size == 0:
        return filled, box, row_spans, col_spans
    # the candidates' box and one pixel more on each side (a candidate is never on the
    # region's border, so none lies on this window's)
    r0, r1 = int(gap_rows[hits[0]].min()) - 1, int(gap_rows[hits[0]].max()) + 2
    c0, c1 = int(gap_cols[hits[1]].min()) - 1, int(gap_cols[hits[1]].max()) + 2
    candidates = _candidates(region, np.arange(r0, r1)[:, None], np.arange(c0, c1), row_first,
                             row_after, col_first, col_after)
    background = ~region[r0:r1, c0:c1]
    labels, count = ndimage.label(candidates, CROSS)
    outside = background & ~candidates
    touching = np.zeros_like(outside)  # pixels with a 4-neighbour outside
    touching[1:] |= outside[:-1]
    touching[:-1] |= outside[1:]
    touching[:, 1:] |= outside[:, :-1]
    touching[:, :-1] |= outside[:, 1:]
    open_label = np.zeros(count + 1, dtype=bool)
    open_label[0] = True  # label 0: not a candidate
    open_label[labels[touching]] = True
    filled[box][r0:r1, c0:c1] |= ~open_label[labels]
    return filled, box, row_spans, col_spans


def _candidates(region, rows, cols, row_first, row_after, col_first, col_after) -> np.ndarray:
    """Whether each pixel (rows[i], cols[j]) of ``region`` (index arrays broadcast against
    each other) is background between mask pixels in both its row and its column."""
    return (~region[rows, cols] & (cols >= row_first[rows]) & (cols < row_after[rows])
            & (rows >= col_first[cols]) & (rows < col_after[cols]))


def _spans(region: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each row of a 2-D boolean array: the index of its first True pixel, one past its
    last, and whether a False pixel lies between them (a row without True pixels: an empty
    span at the end, no gap)."""
    cols = region.shape[1]
    any_row = region.any(axis=1)
    first = np.where(any_row, np.argmax(region, axis=1), cols)
    after = np.where(any_row, cols - np.argmax(region[:, ::-1], axis=1), cols)
    counts = np.add.reduce(region.view(np.uint8), axis=1, dtype=np.uint16 if cols <= 65535 else np.intp)
    return first, after, counts < after - first


def largest_component(mask: np.ndarray, near: tuple[float, float] | None = None) -> np.ndarray:
    """The largest 4-connected region of a boolean mask (an error when it is empty); of
    regions of equal size, the first in raster order. With ``near`` (row, col), the region
    holding that pixel when there is one (the same object as in another image of a pair).
    Only the mask's bounding box is labelled."""
    box = bounding_box(mask)
    if box is None:
        raise RoiError("automatic phantom mask: no pixel above the threshold")
    region = mask[box]
    # n pixels hold at most n / 2 regions (a checkerboard): 16-bit labels when they suffice
    labels, count = ndimage.label(region, CROSS, output=np.uint16 if region.size <= 2 * 65535 else np.int32)
    chosen = 0
    if near is not None:
        row, col = int(round(near[0])) - box[0].start, int(round(near[1])) - box[1].start
        if 0 <= row < labels.shape[0] and 0 <= col < labels.shape[1]:
            chosen = int(labels[row, col])
    component = np.zeros_like(mask)
    component[box] = labels == (chosen or _largest_label(labels, count))
    return component


#: Up to this many regions, their sizes are counted one region at a time.
FEW_REGIONS = 8


def _largest_label(labels: np.ndarray, count: int) -> int:
    """The label (1 to ``count``) of the largest region of ``labels``, the lowest of equal ones."""
    if count <= FEW_REGIONS:  # one pass a region: no temporaries as large as the labels
        sizes = [np.count_nonzero(labels == k) for k in range(1, count + 1)]
        return 1 + int(np.argmax(sizes))
    # many regions: sizes by sorting (np.bincount's one counter per label stalls on a few
    # large regions)
    values, sizes = np.unique(labels, return_counts=True)
    sizes[values == 0] = 0
    return int(values[int(np.argmax(sizes))])


def outline_points(mask: np.ndarray) -> np.ndarray:
    """(N, 2) array of (row, col) outline points: the outer edge of the outermost mask pixel
    in each row (left, right) and column (top, bottom)."""
    box = bounding_box(mask)
    if box is None:
        return np.empty((0, 2))
    region = mask[box]
    return _outline(box, _spans(region), _spans(region.T))


def _outline(box: tuple[slice, slice], row_spans, col_spans) -> np.ndarray:
    """:func:`outline_points` from the :func:`_spans` of the rows and of the columns of the
    mask's bounding box ``box``."""
    (row_first, row_after, _), (col_first, col_after, _) = row_spans, col_spans
    rows, cols = np.flatnonzero(row_first < row_after), np.flatnonzero(col_first < col_after)
    top, left = box[0].start, box[1].start
    ends = [line[used] + (offset - 0.5) for line, used, offset in (
        (row_first, rows, left), (row_after, rows, left), (col_first, cols, top), (col_after, cols, top))]
    rows, cols = (rows + top).astype(float), (cols + left).astype(float)
    return np.concatenate([np.column_stack([rows, ends[0]]), np.column_stack([rows, ends[1]]),
                           np.column_stack([ends[2], cols]), np.column_stack([ends[3], cols])])


def _kasa(columns: np.ndarray) -> tuple[float, float, float]:
    """Least-squares circle (centre x, y, radius) through points given as the rows x, y, 1,
    x^2 + y^2 of ``columns`` (4 x N), from x^2 + y^2 = a x + b y + k, solved by its 3 x 3
    normal equations (well conditioned when x and y are centred)."""
    gram = columns @ columns.T  # every sum of the normal equations at once
    try:
        a, b, k = np.linalg.solve(gram[:3, :3], gram[:3, 3])
    except np.linalg.LinAlgError:  # collinear points (a refit kept one straight edge): least squares
        a, b, k = np.linalg.lstsq(gram[:3, :3], gram[:3, 3], rcond=None)[0]
    return a / 2, b / 2, float(np.sqrt(max(k + (a * a + b * b) / 4, 0.0)))


def _median(values: np.ndarray) -> float:
    """Median of a 1-D array (np.median's value, by one partition without its overhead)."""
    n = values.size
    middle = np.partition(values, (n - 1) // 2 if n % 2 else (n // 2 - 1, n // 2))
    return float(middle[n // 2]) if n % 2 else float((middle[n // 2 - 1] + middle[n // 2]) / 2)


def fit_circle(points: np.ndarray) -> tuple[tuple[float, float, float], float]:
    """Robust circle (row, col, radius) and the fraction of points within OUTLIER_PX of it."""
    centre = points.mean(axis=0)  # the fit works in coordinates centred here
    x, y = points[:, 0] - centre[0], points[:, 1] - centre[1]
    columns = np.stack([x, y, np.ones_like(x), x * x + y * y])
    keep = np.ones(len(points), dtype=bool)
    for _ in range(CIRCLE_REFITS + 1):
        u, v, radius = _kasa(columns[:, keep])
        residual = np.abs(np.hypot(x - u, y - v) - radius)
        mad = 1.4826 * _median(residual[keep])
        new_keep = residual <= max(OUTLIER_PX, 3 * mad)
        if np.count_nonzero(new_keep) < 8 or np.array_equal(new_keep, keep):
            break
        keep = new_keep
    circle = (float(centre[0] + u), float(centre[1] + v), radius)
    return circle, float(np.count_nonzero(residual <= OUTLIER_PX) / len(points))


def fit_rectangle(points: np.ndarray) -> tuple[tuple[float, float, float, float], float]:
    """Axis-aligned rectangle (top, bottom, left, right edges, pixels) from the median outline
    of each side, and the fraction of outline points within OUTLIER_PX of it."""
    r, c = points[:, 0], points[:, 1]
    bounds = r.min(), r.max()  # the top and bottom edges of the mask's bounding box
    left, right = _sides(r, c, *bounds, (c.min(), c.max()))
    top, bottom = _sides(c, r, left, right, bounds)
    inside_r, inside_c = (r >= top - OUTLIER_PX) & (r <= bottom + OUTLIER_PX), (c >= left - OUTLIER_PX) & (c <= right + OUTLIER_PX)
    on_side = (
        (inside_r & ((np.abs(c - left) <= OUTLIER_PX) | (np.abs(c - right) <= OUTLIER_PX)))
        | (inside_c & ((np.abs(r - top) <= OUTLIER_PX) | (np.abs(r - bottom) <= OUTLIER_PX)))
    )
    return (top, bottom, left, right), float(np.mean(on_side))


def _sides(lines: np.ndarray, edges: np.ndarray, lo: float, hi: float,
           at_edges: tuple[float, float]) -> tuple[float, float]:
    """Two opposite sides of a rectangle (pixels): the median ``edges`` coordinate of the
    outline points near each bounding edge ``at_edges``, on the central 60 % of the lines
    between ``lo`` and ``hi``; the bounding edge itself when no point is near it."""
    span = hi - lo
    values = edges[(lines > lo + 0.2 * span) & (lines < hi - 0.2 * span)]
    sides = []
    for at_edge in at_edges:
        near = values[np.abs(values - at_edge) < 0.25 * span]
        sides.append(_median(near) if near.size else float(at_edge))
    return sides[0], sides[1]


#: Slices at least this many pixels on each side are searched at half resolution (2 x 2
#: means: a quarter of the work; the circle fit of ~4 R outline points stays sub-pixel).
BIN_FROM_PX = 384


def find_phantom(image: np.ndarray, near: tuple[float, float] | None = None
                 ) -> tuple[np.ndarray, PhantomFit]:
    """The filled phantom mask of a 2-D slice and the fit of its outline (see the module);
    ``near`` (row, col, pixels) picks the region holding that pixel (the phantom found in the
    other image of a pair) over the largest one."""
    rows, cols = image.shape
    if min(rows, cols) < BIN_FROM_PX:
        return _find(image, near)
    even = image[: rows // 2 * 2, : cols // 2 * 2]
    # the 2 x 2 means as three strided additions (a tenth of the time of a reshaped mean),
    # in float64 whatever the image's type
    binned = np.add(even[0::2, 0::2], even[1::2, 0::2], dtype=np.float64)
    binned += even[0::2, 1::2]
    binned += even[1::2, 1::2]
    binned *= 0.25
    small, fit = _find(binned, None if near is None else ((near[0] - 0.5) / 2, (near[1] - 0.5) / 2))
    mask = np.zeros(image.shape, dtype=bool)
    mask[: rows // 2 * 2, : cols // 2 * 2] = small.repeat(2, axis=0).repeat(2, axis=1)

    def full(point):
        return (2 * point[0] + 0.5, 2 * point[1] + 0.5)

    return mask, PhantomFit(full(fit.centre_px), fit.shape, tuple(2 * v for v in fit.size_px),
                            fit.inlier_fraction, fit.threshold, full(fit.centroid_px))


def phantom_centroid(image: np.ndarray, near: tuple[float, float]) -> tuple[float, float]:
    """The centroid (row, col) of the filled region above :func:`detection_threshold` that
    holds ``near`` (the largest one otherwise), without fitting its outline: which object the
    other image of a pair shows."""
    return _centroid(fill_holes(largest_component(above(image, detection_threshold(image)), near)))


def _find(image: np.ndarray, near=None) -> tuple[np.ndarray, PhantomFit]:
    threshold = detection_threshold(image)
    mask, box, row_spans, col_spans = _filled(largest_component(above(image, threshold), near))
    if mask[0].any() and mask[-1].any() and mask[:, 0].any() and mask[:, -1].any():
        raise RoiError(
            f"automatic phantom mask: the region above the threshold {threshold:.4g} reaches all "
            "four edges of the image; no phantom found (a slice of noise, or a phantom larger "
            "than the field of view)"
        )
    points = _outline(box, row_spans, col_spans)
    (row, col, radius), circle_in = fit_circle(points)
    (top, bottom, left, right), rect_in = fit_rectangle(points)
    centroid = _centroid(mask)
    if circle_in >= rect_in:
        fit = PhantomFit((float(row), float(col)), "circle", (radius,), circle_in, threshold, centroid)
    else:
        fit = PhantomFit(((top + bottom) / 2, (left + right) / 2), "rectangle",
                         ((bottom - top) / 2, (right - left) / 2), rect_in, threshold, centroid)
    return mask, fit


def _centroid(mask: np.ndarray) -> tuple[float, float]:
    """(row, col) centroid of a non-empty boolean mask, from its row and column counts."""
    # counts by an integer sum of the bytes (np.count_nonzero along an axis copies the mask);
    # 16-bit counters hold any row or column of up to 65535 pixels
    counts = mask.view(np.uint8)
    dtype = np.uint16 if max(mask.shape) <= 65535 else np.intp
    rows, cols = np.add.reduce(counts, axis=1, dtype=dtype), np.add.reduce(counts, axis=0, dtype=dtype)
    total = int(rows.sum(dtype=np.intp))
    return (float(np.dot(np.arange(rows.size), rows) / total),
            float(np.dot(np.arange(cols.size), cols) / total))
