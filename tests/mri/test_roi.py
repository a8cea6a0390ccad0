"""ROI parsing and resolution: exact pixel counts of boxes, circles, masks, phantom and nema5."""

from __future__ import annotations

import numpy as np
import pytest

from mri.errors import RoiError
from mri.phantom import find_phantom
from mri.roi import parse_roi, resolve_roi


def disc_image(size=128, radius=40, centre=(64, 70), value=100.0, seed=0):
    rng = np.random.default_rng(seed)
    r, c = np.ogrid[:size, :size]
    inside = (r - centre[0]) ** 2 + (c - centre[1]) ** 2 <= radius**2
    return np.where(inside, value, 0.0) + rng.normal(0, 2.0, (size, size)), inside


def resolve(text, image, spacing=None, k=0, loader=None):
    return resolve_roi(parse_roi(text, loader), image, spacing, k)


def test_box_is_top_left_zero_based():
    (roi,) = resolve("box:2:3:4:5", np.zeros((10, 12)))
    rows, cols = np.nonzero(roi.mask)
    assert (rows.min(), rows.max(), cols.min(), cols.max()) == (2, 5, 3, 7)
    assert roi.n_pixels == 20 and roi.label == "box:2:3:4:5"


def test_central_box_and_circle_in_pixels_and_mm():
    image = np.zeros((100, 120))
    (box,) = resolve("central-box:10", image)
    assert box.n_pixels == 100 and box.label.endswith("box:45:55:10:10")
    # 10 mm at 0.5 mm (rows) x 1.0 mm (cols) pixels: 20 x 10 pixels
    (box_mm,) = resolve("central-box:10mm", image, spacing=(0.5, 1.0))
    assert box_mm.n_pixels == 200 and box_mm.label.endswith("box:40:55:20:10")
    (circle,) = resolve("central-circle:40", image)
    assert circle.n_pixels == pytest.approx(np.pi * 20**2, rel=0.02)
    with pytest.raises(RoiError, match="in mm but the image has no pixel spacing"):
        resolve("central-circle:40mm", image)


def test_whole_and_mask_file():
    image = np.zeros((6, 7))
    (whole,) = resolve("whole", image)
    assert whole.n_pixels == 42
    mask = np.zeros((2, 6, 7))
    mask[1, 1:3, 1:4] = 1
    (roi,) = resolve("mask:m.npy", image, k=1, loader=lambda path: mask)
    assert roi.n_pixels == 6
    with pytest.raises(RoiError, match="does not match"):
        resolve("mask:m.npy", np.zeros((6, 8)), loader=lambda path: mask)


def test_phantom_mask_finds_the_disc_and_erodes_it():
    image, inside = disc_image()
    found, _ = find_phantom(image)
    assert np.sum(found ^ inside) < 0.02 * inside.sum()
    (eroded,) = resolve("phantom:5", image)
    # disc of radius 40 eroded by 5 px: radius 35 (pixel-count tolerance 3 %)
    assert eroded.n_pixels == pytest.approx(np.pi * 35**2, rel=0.03)
    (eroded_mm,) = resolve("phantom:2.5mm", image, spacing=(0.5, 0.5))
    assert eroded_mm.n_pixels == eroded.n_pixels


def test_nema5_boxes_around_the_phantom_centre():
    image, _ = disc_image(radius=50, centre=(64, 70))
    rois = resolve("nema5:10:20", image)
    assert [r.label.split()[1] for r in rois] == [
        "centre", "upper-left", "lower-left", "upper-right", "lower-right"]
    # a 10 px box on centre (64, 70) spans 59.5-68.5 x 65.5-74.5: the first row and column
    # round half to even, to 60 and 66
    assert rois[0].label.endswith("box:60:66:10:10")
    assert all(r.n_pixels == 100 for r in rois)
    with pytest.raises(RoiError, match="outside the phantom"):
        resolve("nema5:20:45", image)


@pytest.mark.parametrize(
    "text, message",
    [
        ("box:1:2", "ROW:COL:HEIGHT:WIDTH"),
        ("box:1:2:0:4", "at least 1 pixel"),
        ("box:-1:2:3:4", "ROW:COL:HEIGHT:WIDTH"),
        ("central-box:abc", "positive number"),
        ("central-circle", "takes 1 to 1"),
        ("ellipse:3", "not understood"),
    ],
)
def test_malformed_roi_text(text, message):
    with pytest.raises(RoiError, match=message):
        parse_roi(text)


@pytest.mark.parametrize(
    "text, message",
    [
        ("box:250:250:20:20", "extend outside the 256 x 256 image"),
        ("box:10:10:1:1", "holds 1 pixel"),
        ("central-circle:1", "holds 0 pixel"),
        ("central-box:300", "does not fit"),
    ],
)
def test_empty_or_outside_roi(text, message):
    with pytest.raises(RoiError, match=message):
        resolve(text, np.zeros((256, 256)))


def test_uniform_image_has_no_phantom():
    with pytest.raises(RoiError, match="uniform"):
        resolve("phantom", np.full((20, 20), 7.0))


def test_box_roi_mask_is_made_on_demand_and_clipped_to_the_image():
    from mri.roi import Roi

    roi = Roi("box", None, (-2, 5, 4, 10), (6, 12))  # reaches above the image and past its right
    expected = np.zeros((6, 12), dtype=bool)
    expected[0:2, 5:12] = True
    np.testing.assert_array_equal(roi.mask, expected)
    assert roi.n_pixels == 40  # a box's area, as measured on the block
    with pytest.raises(ValueError, match="a box and the image shape"):
        Roi("box", None, (0, 0, 2, 2))
