"""Phantom detection against synthetic phantoms of known centre (shaded, notched, with a flat
air bubble, with inserts, rectangles) and against the centre hazen pins for the real pair.

Tolerance: 0.6 px on the centre. The outline is found to the pixel and a circle fit over
~700 outline points averages that quantisation down; partial-volume edge pixels under strong
shading move the outline by up to ~0.3 px on the dark side (a pixel joins the mask when its
share of the edge lifts it over the threshold, which is set by the air's noise), and a rectangle's sides are medians of whole pixels (+-0.5 px).
The naive method (Otsu mask, holes filled, centroid) is run on the same images to show that
the cases are hard: it misses by 2-8 px.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from mri.errors import BoxOutsidePhantomError
from mri.phantom import (
    AIR_CORNER_DIVISOR,
    AIR_SIGMAS,
    CEILING_FRACTION,
    FLOOR_FRACTION,
    _median,
    above,
    air_threshold,
    detection_threshold,
    fill_holes,
    find_phantom,
    fit_circle,
    largest_component,
    outline_points,
)
from mri.roi import parse_roi, resolve_roi
from tests.mri.phantoms import noisy_pair, phantom

CENTRE = (121.3, 133.6)

CASES = {
    "plain": dict(),
    "linear shading 4:1": dict(shading=("linear", 0.25)),
    "radial shading, dark centre": dict(shading=("radial", 0.25)),
    "notch": dict(notch=(180, 25, 30)),
    "air bubble": dict(chord_depth=12),
    "dark insert at the centre": dict(inserts=((121, 133, 15, 0.02),)),
    "bright insert": dict(inserts=((80, 100, 10, 3.0),)),
    "everything": dict(shading=("radial", 0.25), notch=(30, 20, 25), chord_depth=10,
                       inserts=((121, 133, 15, 0.02),)),
    "rectangle": dict(kind="rectangle"),
    "shaded rectangle": dict(kind="rectangle", shading=("linear", 0.3)),
}
#: Cases where the naive centroid of an Otsu mask misses the centre by more than 2 px.
HARD = ("linear shading 4:1", "notch", "air bubble", "everything", "shaded rectangle")


def naive_centre(image):
    from skimage.filters import threshold_otsu

    return ndimage.center_of_mass(ndimage.binary_fill_holes(image > threshold_otsu(image)))


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("sigma", [20.0, 80.0])
def test_centre_of_shaded_notched_and_insert_phantoms(case, sigma):
    a, _ = noisy_pair(phantom(centre=CENTRE, **CASES[case]), sigma, seed=7)
    _, fit = find_phantom(a)
    assert fit.shape == ("rectangle" if "rectangle" in case else "circle")
    assert np.hypot(*np.subtract(fit.centre_px, CENTRE)) < 0.6, fit
    if case in HARD:
        assert np.hypot(*np.subtract(naive_centre(a), CENTRE)) > 2.0


def test_radius_and_half_sizes():
    a, _ = noisy_pair(phantom(centre=CENTRE, radius=95.0), 20.0, seed=1)
    assert find_phantom(a)[1].size_px[0] == pytest.approx(95.0, abs=0.5)
    a, _ = noisy_pair(phantom(centre=CENTRE, kind="rectangle", half_size=(70.0, 100.0)), 20.0, seed=1)
    np.testing.assert_allclose(find_phantom(a)[1].size_px, (70.0, 100.0), atol=0.6)


def test_nema5_boxes_are_measured_on_a_dark_centre_and_an_insert():
    # Centre at 25 % of the edge brightness (a receive array), a dark insert under the centre
    # box, a notch and an air bubble: every box lies inside the phantom, so none is refused.
    a, _ = noisy_pair(phantom(centre=CENTRE, **CASES["everything"]), 100.0, seed=3)
    rois = resolve_roi(parse_roi("nema5"), a, None)
    assert rois[0].label == "nema5 centre box:112:124:20:20"  # round(121.3 - 9.5), round(133.6 - 9.5)
    assert [r.n_pixels for r in rois] == [400] * 5


def test_a_given_layout_that_leaves_the_phantom_is_refused_with_the_boxes_to_draw():
    a, _ = noisy_pair(phantom(centre=CENTRE, radius=45.0), 20.0, seed=4)
    with pytest.raises(BoxOutsidePhantomError, match="upper-left, lower-left, upper-right, "
                       "lower-right box") as info:
        resolve_roi(parse_roi("nema5:20:40"), a, None)
    assert len(info.value.rois) == 5 and info.value.fit.shape == "circle"
    # the same boxes fit once they are brought in
    assert len(resolve_roi(parse_roi("nema5:20:20"), a, None)) == 5


def test_the_default_layout_shrinks_to_the_largest_that_fits_and_says_so():
    # radius 45: 20 px boxes fit at offset o when (o + 10) sqrt 2 <= ~45, i.e. o <= 21
    a, _ = noisy_pair(phantom(centre=CENTRE, radius=45.0), 20.0, seed=4)
    rois = resolve_roi(parse_roi("nema5"), a, None)
    note = rois[0].note
    assert note.code == "boxes_shrunk" and note.values["size_px"] == 20
    assert 18 <= note.values["offset_px"] <= 22, note
    assert all(r.box[2:] == (20, 20) for r in rois) and all(r.note is None for r in rois[1:])
    # every box inside the disc (corner distance from the true centre below the radius)
    for r in rois:
        row, col, h, w = r.box
        corners = [(row - 0.5 + dr, col - 0.5 + dc) for dr in (0, h) for dc in (0, w)]
        assert max(np.hypot(y - CENTRE[0], x - CENTRE[1]) for y, x in corners) <= 45.0 + 0.5


def test_a_phantom_too_small_for_five_px_boxes_is_refused():
    # radius 9 px: five 5 px boxes (centre and diagonals) need about 2.5 x 5 sqrt 2 = 17.7 px
    a, _ = noisy_pair(phantom(shape=(64, 64), centre=(31.3, 32.6), radius=9.0), 20.0, seed=4)
    with pytest.raises(BoxOutsidePhantomError, match="even 5 x 5 px boxes do not fit"):
        resolve_roi(parse_roi("nema5"), a, None)


def test_a_box_over_a_notch_is_refused_or_brought_in():
    # A notch cut 30 px into the upper right: the upper-right box (rows 72-91, cols 164-183)
    # falls into the air of the notch. The given layout is refused; the default one moves
    # its boxes inwards, clear of the notch.
    a, _ = noisy_pair(phantom(centre=CENTRE, notch=(45, 50, 40)), 20.0, seed=5)
    with pytest.raises(BoxOutsidePhantomError, match="the upper-right box"):
        resolve_roi(parse_roi("nema5:20:40"), a, None)
    mask, _ = find_phantom(a)
    rois = resolve_roi(parse_roi("nema5"), a, None)
    assert rois[0].note.code == "boxes_shrunk" and rois[0].note.values["offset_px"] < 40
    assert all(mask[r.box[0]:r.box[0] + r.box[2], r.box[1]:r.box[1] + r.box[3]].all() for r in rois)


def test_flipped_image_gives_the_flipped_layout():
    a, _ = noisy_pair(phantom(centre=CENTRE, **CASES["everything"]), 20.0, seed=6)
    boxes = [r.box for r in resolve_roi(parse_roi("nema5"), a, None)]
    flipped = [r.box for r in resolve_roi(parse_roi("nema5"), a[::-1], None)]
    rows = a.shape[0]
    assert sorted(flipped) == sorted((rows - r - h, c, h, w) for r, c, h, w in boxes)


def test_fill_holes_and_largest_component_match_scipy():
    # fill_holes labels only the hole candidates (faster); it must equal scipy's fill.
    rng = np.random.default_rng(3)
    for _ in range(5):
        blob = np.zeros((60, 70), dtype=bool)
        blob[5:50, 10:60] = rng.random((45, 50)) > 0.3
        np.testing.assert_array_equal(fill_holes(blob), ndimage.binary_fill_holes(blob))
        labels, _ = ndimage.label(blob)
        sizes = ndimage.sum(blob, labels, range(1, labels.max() + 1))
        np.testing.assert_array_equal(largest_component(blob), labels == 1 + int(np.argmax(sizes)))


def test_largest_component_with_few_regions_and_ties():
    # up to 8 regions are sized one at a time; equal regions: the first in raster order wins
    mask = np.zeros((40, 50), dtype=bool)
    mask[30:35, 5:10] = mask[5:10, 40:45] = True  # two 5 x 5 squares; (5, 40) comes first
    mask[20, 20] = True
    expected = np.zeros_like(mask)
    expected[5:10, 40:45] = True
    np.testing.assert_array_equal(largest_component(mask), expected)
    mask[12:16, 1:3] = mask[36:39, 30:49] = True  # five regions, the last one largest
    labels, _ = ndimage.label(mask)
    np.testing.assert_array_equal(largest_component(mask), labels == labels[37, 40])


def test_fill_holes_equals_scipy_on_random_masks():
    # many small regions, holes next to open bays, empty rows and columns inside the box:
    # every case of the candidate test (a gap in both the row and the column) and of the
    # labelling of candidates; exact equality with scipy's flood of the background
    rng = np.random.default_rng(5)
    for k in range(400):
        mask = rng.random(tuple(rng.integers(2, 30, 2))) < rng.uniform(0.2, 0.9)
        if k % 2:
            mask = ndimage.binary_opening(mask)
        np.testing.assert_array_equal(fill_holes(mask), ndimage.binary_fill_holes(mask))


def test_fill_holes_without_labelling_matches_scipy():
    # masks without a pixel that has a gap in both its row and its column skip the
    # labelling: open notches and bumps are no holes; a ring closed in both directions is
    # refilled by the labelling.
    r, c = np.ogrid[:80, :90]
    disc = (r - 40) ** 2 + (c - 45) ** 2 <= 30**2
    notched = disc & ~((np.abs(c - 45) < 4) & (r < 30))  # open at the top: rows have 2 runs
    bumps = disc.copy()
    bumps[5:20, 30:33] = bumps[5:20, 55:58] = True  # two bumps on top: every column one run
    ring = disc & ((r - 40) ** 2 + (c - 45) ** 2 >= 10**2)
    u_shape = disc & ~((np.abs(c - 45) < 4) & (r < 50))  # a slot from the top edge
    for mask in (disc, notched, bumps, ring, u_shape, ring.T, notched.T):
        np.testing.assert_array_equal(fill_holes(mask), ndimage.binary_fill_holes(mask))
    assert fill_holes(ring).sum() == disc.sum()
    runs = [(np.diff(np.pad(m, ((0, 0), (1, 0))).astype(int), axis=1) == 1).sum(axis=1).max()
            for m in (bumps, bumps.T)]
    assert runs[0] > 1 and runs[1] == 1  # the case the column test answers


def _outline_by_loops(mask):
    points = []
    rows = [i for i in range(mask.shape[0]) if mask[i].any()]
    cols = [j for j in range(mask.shape[1]) if mask[:, j].any()]
    points += [(i, np.flatnonzero(mask[i])[0] - 0.5) for i in rows]
    points += [(i, np.flatnonzero(mask[i])[-1] + 0.5) for i in rows]
    points += [(np.flatnonzero(mask[:, j])[0] - 0.5, j) for j in cols]
    points += [(np.flatnonzero(mask[:, j])[-1] + 0.5, j) for j in cols]
    return np.array(points, dtype=float)


def test_outline_points_are_the_outer_edges_of_each_row_and_column():
    rng = np.random.default_rng(4)
    for _ in range(4):
        mask = np.zeros((50, 60), dtype=bool)
        mask[7:41, 12:55] = rng.random((34, 43)) > 0.5  # rows and columns without pixels
        mask[20, 3] = True
        np.testing.assert_array_equal(outline_points(mask), _outline_by_loops(mask))
    assert outline_points(np.zeros((5, 5), dtype=bool)).shape == (0, 2)


def test_circle_fit_equals_least_squares_and_median_equals_numpy():
    rng = np.random.default_rng(5)
    angle = rng.uniform(0, 2 * np.pi, 300)
    points = np.column_stack([60.3 + 40 * np.sin(angle), 70.9 + 40 * np.cos(angle)])
    points += rng.normal(0, 0.3, points.shape)
    points[:30] += 6.0  # outliers, dropped by the refits
    (row, col, radius), inliers = fit_circle(points)
    # the kept points' ordinary least-squares (Kasa) circle, by numpy's lstsq
    residual = np.abs(np.hypot(points[:, 0] - row, points[:, 1] - col) - radius)
    kept = points[residual <= max(1.5, 3 * 1.4826 * np.median(residual))]
    x, y = kept[:, 0] - 60, kept[:, 1] - 70
    (a, b, k), *_ = np.linalg.lstsq(np.column_stack([x, y, np.ones_like(x)]), x * x + y * y, rcond=None)
    np.testing.assert_allclose((row, col, radius), (60 + a / 2, 70 + b / 2, np.sqrt(k + (a * a + b * b) / 4)),
                               rtol=1e-12)
    assert abs(row - 60.3) < 0.1 and abs(col - 70.9) < 0.1 and 0.85 < inliers < 0.95
    for n in (1, 2, 7, 10):
        values = rng.normal(size=n)
        assert _median(values) == np.median(values)


def test_circle_fit_of_collinear_points_is_finite_and_fits_nothing():
    # a straight edge (a refit may keep only one): the normal equations are singular; the fit
    # falls back to least squares instead of raising, and no point lies on its circle
    points = np.column_stack([np.full(20, 10.5), np.arange(20) + 0.5])
    (row, col, radius), inliers = fit_circle(points)
    assert np.isfinite([row, col, radius]).all() and inliers < 0.5


def test_float32_pixels_are_compared_with_the_threshold_in_float64():
    # 1 + 2**-23 (a float32) is above 1.00000007; float32 would round the threshold up to it
    pixels = np.array([[1.0, 1.0 + 2.0**-23], [1.0 + 2.0**-22, 0.5]], dtype=np.float32)
    assert above(pixels, 1.00000007).tolist() == [[False, True], [True, False]]
    np.testing.assert_array_equal(above(pixels, 1.00000007), pixels.astype(np.float64) > 1.00000007)
    a, _ = noisy_pair(phantom(centre=CENTRE, shading=("linear", 0.3)), 20.0, seed=11)
    narrow, wide = find_phantom(a.astype(np.float32)), find_phantom(a.astype(np.float32).astype(np.float64))
    np.testing.assert_array_equal(narrow[0], wide[0])
    assert narrow[1] == wide[1]


def test_large_slices_are_searched_at_half_resolution_with_the_same_centre():
    # 512 x 512 (binned 2 x 2 for speed): the centre stays within the 0.6 px tolerance.
    truth = phantom(shape=(512, 512), centre=(250.3, 260.7), radius=190.0, **CASES["everything"] |
                    dict(inserts=((250, 260, 30, 0.02),), notch=(30, 40, 50), chord_depth=20))
    a, _ = noisy_pair(truth, 60.0, seed=8)
    mask, fit = find_phantom(a)
    assert mask.shape == a.shape and fit.shape == "circle"
    assert np.hypot(fit.centre_px[0] - 250.3, fit.centre_px[1] - 260.7) < 0.6


def test_thresholds_equal_numpys_mean_std_median_and_order_statistics():
    # the corner mean and std come from one sum and the percentiles from two single
    # partitions: the same numbers, to the bit, as np.mean, np.std, np.median and a sort
    rng = np.random.default_rng(8)
    for shape, dtype in (((64, 64), np.float32), ((256, 200), np.float32), ((37, 50), np.float64)):
        image = phantom(shape=shape, centre=(shape[0] / 2, shape[1] / 2), radius=min(shape) / 3) + rng.rayleigh(5.0, shape)
        image = image.astype(dtype)
        side = min(shape) // AIR_CORNER_DIVISOR
        corners = [image[:side, :side], image[:side, -side:], image[-side:, :side], image[-side:, -side:]]
        air = float(np.median([np.mean(c, dtype=np.float64) + AIR_SIGMAS * np.std(c, dtype=np.float64)
                               for c in corners]))
        assert air_threshold(image) == air
        sample = np.sort(image.ravel()[::4] if image.size >= 4096 else image.ravel())
        n = sample.size - 1
        lo, hi = float(sample[round(n * 0.01)]), float(sample[round(n * 0.99)])
        expected = min(max(air, lo + FLOOR_FRACTION * (hi - lo)), lo + CEILING_FRACTION * (hi - lo))
        assert detection_threshold(image) == expected
