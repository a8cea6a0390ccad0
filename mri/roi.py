"""Regions of interest: parsed from text, then resolved to pixel masks on one slice.

ROI texts (sizes are pixels, or millimetres with an ``mm`` suffix; boxes are zero-based):

``whole``                          every pixel (the thesis' eq 91 over the whole image)
``box:ROW:COL:HEIGHT:WIDTH``       explicit box in pixels, top-left corner at (ROW, COL)
``central-box:SIZE[:WIDTH]``       box centred on the image, SIZE x SIZE (or SIZE x WIDTH)
``central-circle:DIAMETER``        disc centred on the image
``mask:PATH``                      non-zero pixels of an image file of the same size
``phantom[:EROSION]``              automatic phantom mask (:func:`mri.phantom.find_phantom`:
                                   shading-robust threshold, largest region, holes filled),
                                   eroded by EROSION, default 5 px
``nema5[:SIZE[:OFFSET]]``          five SIZE boxes (default 20 px) on the phantom centre (fitted
                                   circle or rectangle of the outline, :mod:`mri.phantom`) and
                                   at (+-OFFSET, +-OFFSET) from it (default 40 px), as MRI QA
                                   tools (hazen, McCann et al. 2013) place them for NEMA MS 1;
                                   every box must lie inside the phantom (holes filled): the
                                   default layout shrinks to the largest that does (the largest
                                   size, down to NEMA5_MIN_SIZE_PX, at its largest offset), a given one
                                   or a phantom too small raises
                                   :class:`BoxOutsidePhantomError` with the boxes to draw
``corners[:SIZE]``                 four SIZE boxes (default 1/8 of the image) in the image
                                   corners, CORNER_INSET_PX from the edges: the air ROIs of the
                                   background method; each must stay BACKGROUND_MARGIN_PX clear
                                   of the phantom
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from mri.errors import BoxOutsidePhantomError, RoiError
from mri.phantom import find_phantom

#: Default erosion of the automatic phantom mask (pixels) and NEMA box layout (pixels).
PHANTOM_EROSION_PX = 5
NEMA5_SIZE_PX = 20
NEMA5_OFFSET_PX = 40
#: Corner boxes: distance from the image edges, and the clearance kept from the phantom (px).
CORNER_INSET_PX = 2
BACKGROUND_MARGIN_PX = 3

_LENGTH = re.compile(r"^(\d+(?:\.\d+)?)(mm|px)?$")


@dataclass(frozen=True)
class Length:
    """A length given on the command line: ``value`` in ``unit`` ("px" or "mm")."""

    value: float
    unit: str

    def pixels(self, spacing_mm: float | None, text: str) -> float:
        """The length in pixels along an axis of spacing ``spacing_mm`` (mm/pixel)."""
        if self.unit == "px":
            return self.value
        if spacing_mm is None:
            raise RoiError(
                f"ROI {text!r} is sized in mm but the image has no pixel spacing; "
                "give the size in pixels"
            )
        return self.value / spacing_mm


@dataclass(frozen=True, eq=False)
class RoiSpec:
    """A parsed ROI text; ``mask`` holds the (slices, rows, cols) array of a ``mask:`` ROI."""

    text: str
    kind: str
    lengths: tuple[Length, ...] = ()
    box: tuple[int, int, int, int] | None = None
    mask: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class Roi:
    """A resolved ROI on one slice: its label (reproducible ROI text) and its pixels, as a
    boolean ``pixel_mask`` or, for rectangles, as the box (row, col, height, width) in pixels
    of an image of ``shape`` (rows, cols), which measures slice directly. :attr:`mask` is
    the boolean mask either way. ``note`` is a :class:`mri.quality.QualityWarning` when the
    ROI was placed otherwise than asked (a shrunk default layout)."""

    label: str
    pixel_mask: np.ndarray | None = None
    box: tuple[int, int, int, int] | None = None
    shape: tuple[int, int] | None = None
    note: object = None  # a mri.quality.QualityWarning on how the ROI was placed

    def __post_init__(self):
        if self.pixel_mask is None and (self.box is None or self.shape is None):
            raise ValueError(f"ROI {self.label!r}: give a pixel mask, or a box and the image shape")

    @property
    def mask(self) -> np.ndarray:
        """The boolean mask of the image (a box's is made when asked for, clipped to the image)."""
        if self.pixel_mask is not None:
            return self.pixel_mask
        row, col, height, width = self.box
        mask = np.zeros(self.shape, dtype=bool)
        mask[max(row, 0) : max(row + height, 0), max(col, 0) : max(col + width, 0)] = True
        return mask

    def pixels(self, image: np.ndarray) -> np.ndarray:
        """The ROI's part of ``image``: a 2-D block for boxes, a 1-D selection otherwise."""
        if self.box is None:
            return image[self.mask]
        row, col, height, width = self.box
        return image[row : row + height, col : col + width]

    @property
    def n_pixels(self) -> int:
        """Pixels in the ROI (a box's is its area: no pass over the mask)."""
        return self.box[2] * self.box[3] if self.box is not None else int(self.mask.sum())


def _length(token: str, text: str) -> Length:
    m = _LENGTH.match(token.strip().lower())
    if not m or float(m.group(1)) <= 0:
        raise RoiError(
            f"ROI {text!r}: size {token!r} must be a positive number of pixels or mm (e.g. 20, 15mm)"
        )
    return Length(float(m.group(1)), m.group(2) or "px")


def parse_roi(text: str, mask_loader=None) -> RoiSpec:
    """Parse one ROI text (see the module docstring); ``mask_loader(path)`` reads ``mask:`` files."""
    kind, _, rest = text.strip().partition(":")
    kind = kind.lower()
    args = rest.split(":") if rest else []
    if kind == "whole" and not args:
        return RoiSpec(text, kind)
    if kind == "box":
        if len(args) != 4 or not all(re.fullmatch(r"\d+", a.strip()) for a in args):
            raise RoiError(
                f"ROI {text!r}: expected box:ROW:COL:HEIGHT:WIDTH with four whole numbers of "
                "pixels (top-left corner, zero-based)"
            )
        row, col, height, width = (int(a) for a in args)
        if height < 1 or width < 1:
            raise RoiError(f"ROI {text!r}: HEIGHT and WIDTH must be at least 1 pixel")
        return RoiSpec(text, kind, box=(row, col, height, width))
    if kind in ("central-box", "central-circle", "phantom", "nema5", "corners"):
        most = {"central-box": 2, "central-circle": 1, "phantom": 1, "nema5": 2, "corners": 1}[kind]
        least = 1 if kind.startswith("central") else 0
        if not least <= len(args) <= most:
            raise RoiError(f"ROI {text!r}: {kind} takes {least} to {most} size(s); see --help")
        return RoiSpec(text, kind, lengths=tuple(_length(a, text) for a in args))
    if kind == "mask" and rest:
        if mask_loader is None:
            raise RoiError(f"ROI {text!r}: mask files are not available here")
        return RoiSpec(text, kind, mask=np.asarray(mask_loader(rest)) != 0)
    raise RoiError(
        f"ROI {text!r} not understood; use whole, box:ROW:COL:HEIGHT:WIDTH, central-box:SIZE, "
        "central-circle:DIAMETER, mask:PATH, phantom[:EROSION], nema5[:SIZE[:OFFSET]] or "
        "corners[:SIZE]"
    )


# --------------------------------------------------------------------------- phantom


def _eroded(mask: np.ndarray, radius_px: tuple[float, float]) -> np.ndarray:
    """Erode ``mask`` by an ellipse of radii (rows, cols) in pixels (a disc for square pixels)."""
    distance = ndimage.distance_transform_edt(mask, sampling=(1.0 / radius_px[0], 1.0 / radius_px[1]))
    return distance > 1.0


# --------------------------------------------------------------------------- resolution


def _check_box(shape, row: int, col: int, height: int, width: int, text: str) -> None:
    """An error naming ROI ``text`` when the box leaves the image of ``shape``."""
    rows, cols = shape
    if row < 0 or col < 0 or row + height > rows or col + width > cols:
        raise RoiError(
            f"ROI {text!r}: box rows {row}-{row + height - 1}, columns {col}-{col + width - 1} "
            f"extend outside the {rows} x {cols} image"
        )


def _box_label(row, col, height, width) -> str:
    return f"box:{row}:{col}:{height}:{width}"


def _central_box(spec: RoiSpec, shape, spacing) -> Roi:
    hl = spec.lengths[0]
    wl = spec.lengths[1] if len(spec.lengths) > 1 else hl
    height = int(round(hl.pixels(spacing[0] if spacing else None, spec.text)))
    width = int(round(wl.pixels(spacing[1] if spacing else None, spec.text)))
    if height < 1 or width < 1 or height > shape[0] or width > shape[1]:
        raise RoiError(
            f"ROI {spec.text!r}: a {height} x {width} pixel box does not fit the "
            f"{shape[0]} x {shape[1]} image"
        )
    row, col = (shape[0] - height) // 2, (shape[1] - width) // 2
    box = (row, col, height, width)
    _check_box(shape, *box, spec.text)
    return Roi(f"{spec.text} = {_box_label(*box)}", None, box, shape)


def _central_circle(spec: RoiSpec, shape, spacing) -> Roi:
    d = spec.lengths[0]
    radius = (
        d.pixels(spacing[0] if spacing else None, spec.text) / 2,
        d.pixels(spacing[1] if spacing else None, spec.text) / 2,
    )
    r, c = np.ogrid[: shape[0], : shape[1]]
    centre = ((shape[0] - 1) / 2, (shape[1] - 1) / 2)
    mask = ((r - centre[0]) / radius[0]) ** 2 + ((c - centre[1]) / radius[1]) ** 2 <= 1.0
    if 2 * radius[0] > shape[0] or 2 * radius[1] > shape[1]:
        raise RoiError(
            f"ROI {spec.text!r}: a circle {2 * radius[0]:.1f} x {2 * radius[1]:.1f} pixels across "
            f"does not fit the {shape[0]} x {shape[1]} image"
        )
    return Roi(spec.text, mask)


NEMA5_NAMES = ("centre", "upper-left", "lower-left", "upper-right", "lower-right")
NEMA5_DIRECTIONS = ((0, 0), (-1, -1), (1, -1), (-1, 1), (1, 1))


def nema5_boxes(centre_px, size_px, offset_px) -> tuple[tuple[str, tuple[int, int, int, int]], ...]:
    """The five (name, (row, col, height, width)) boxes centred on ``centre_px`` (row, col,
    fractional) and on (+-offset rows, +-offset cols) from it. A box of even size is centred
    on a pixel corner: its first row is round(centre - (size - 1) / 2), so the layout of a
    flipped image is the flipped layout."""
    return tuple(
        (name, (int(round(centre_px[0] + dr * offset_px[0] - (size_px[0] - 1) / 2)),
                int(round(centre_px[1] + dc * offset_px[1] - (size_px[1] - 1) / 2)),
                size_px[0], size_px[1]))
        for name, (dr, dc) in zip(NEMA5_NAMES, NEMA5_DIRECTIONS)
    )


#: Smallest box side (pixels) of a shrunk default layout: 25 pixels estimate sigma to 14 %.
NEMA5_MIN_SIZE_PX = 5


def _fits(boxes, phantom: np.ndarray) -> list[str]:
    """The names of the boxes that leave the image or the (filled) phantom mask."""
    rows, cols = phantom.shape
    return [name for name, (r, c, h, w) in boxes
            if r < 0 or c < 0 or r + h > rows or c + w > cols or not phantom[r : r + h, c : c + w].all()]


def _largest_layout(fit, phantom: np.ndarray) -> tuple[int, int] | None:
    """The (size, offset) in pixels of the largest NEMA layout inside the phantom, size first
    (from NEMA5_SIZE_PX down to NEMA5_MIN_SIZE_PX), then offset (from NEMA5_OFFSET_PX down
    to the size, where the boxes would touch); None when even the smallest does not fit."""
    for size in range(NEMA5_SIZE_PX, NEMA5_MIN_SIZE_PX - 1, -1):
        for offset in range(NEMA5_OFFSET_PX, size - 1, -1):
            if not _fits(nema5_boxes(fit.centre_px, (size, size), (offset, offset)), phantom):
                return size, offset
    return None


def _nema5(spec: RoiSpec, image: np.ndarray, spacing, found) -> tuple[Roi, ...]:
    """The five NEMA boxes; the default layout shrinks to the largest that fits (a note on
    the centre box says so), an explicit one is refused when a box leaves the phantom."""
    size_l = spec.lengths[0] if spec.lengths else Length(NEMA5_SIZE_PX, "px")
    off_l = spec.lengths[1] if len(spec.lengths) > 1 else Length(NEMA5_OFFSET_PX, "px")
    sr, sc = spacing if spacing else (None, None)
    size = (int(round(size_l.pixels(sr, spec.text))), int(round(size_l.pixels(sc, spec.text))))
    offset = (off_l.pixels(sr, spec.text), off_l.pixels(sc, spec.text))
    phantom, fit = found
    boxes = nema5_boxes(fit.centre_px, size, offset)
    outside = _fits(boxes, phantom)
    note = None
    if outside and not spec.lengths:
        layout = _largest_layout(fit, phantom)
        if layout is not None:
            from mri.quality import QualityWarning

            boxes = nema5_boxes(fit.centre_px, (layout[0],) * 2, (layout[1],) * 2)
            outside, note = [], QualityWarning(
                "boxes_shrunk",
                f"the default NEMA boxes ({NEMA5_SIZE_PX} px at {NEMA5_OFFSET_PX} px from the "
                f"centre) leave the phantom ({', '.join(_fits(nema5_boxes(fit.centre_px, size, offset), phantom))}); "
                f"measured with {layout[0]} px boxes at {layout[1]} px (nema5:{layout[0]}:{layout[1]})",
                {"size_px": layout[0], "offset_px": layout[1], "default_size_px": NEMA5_SIZE_PX,
                 "default_offset_px": NEMA5_OFFSET_PX})
    rois = tuple(Roi(f"nema5 {name} {_box_label(*box)}", None, box, image.shape,
                     note if name == "centre" else None) for name, box in boxes)
    if outside:
        centre = ", ".join(f"{v:.1f}" for v in fit.centre_px)
        smallest = "" if spec.lengths else (f"; even {NEMA5_MIN_SIZE_PX} x {NEMA5_MIN_SIZE_PX} px "
                                             "boxes do not fit")
        raise BoxOutsidePhantomError(
            f"ROI {spec.text!r}: the {', '.join(outside)} box(es) reach outside the phantom "
            f"({fit.shape} centre row, col {centre}, found at threshold {fit.threshold:.4g})"
            f"{smallest}; use smaller nema5:SIZE:OFFSET or explicit boxes",
            rois, fit,
        )
    return rois


def _corners(spec: RoiSpec, image: np.ndarray, spacing, found) -> tuple[Roi, ...]:
    rows, cols = image.shape
    size_l = spec.lengths[0] if spec.lengths else Length(min(rows, cols) // 8, "px")
    sr, sc = spacing if spacing else (None, None)
    size = (int(round(size_l.pixels(sr, spec.text))), int(round(size_l.pixels(sc, spec.text))))
    inset = CORNER_INSET_PX
    if size[0] + inset > rows // 2 or size[1] + inset > cols // 2:
        raise RoiError(f"ROI {spec.text!r}: corner boxes of {size[0]} x {size[1]} px do not fit "
                       f"the {rows} x {cols} image")
    near = ndimage.binary_dilation(found[0], iterations=BACKGROUND_MARGIN_PX)
    rois = []
    for name, row, col in (("upper-left", inset, inset), ("upper-right", inset, cols - inset - size[1]),
                           ("lower-left", rows - inset - size[0], inset),
                           ("lower-right", rows - inset - size[0], cols - inset - size[1])):
        box = (row, col, size[0], size[1])
        label = f"corners {name} {_box_label(*box)}"
        if near[row : row + size[0], col : col + size[1]].any():
            raise RoiError(
                f"ROI {spec.text!r}: the {name} corner box {_box_label(*box)} comes within "
                f"{BACKGROUND_MARGIN_PX} px of the phantom; give smaller corners:SIZE or "
                "explicit background boxes"
            )
        _check_box(image.shape, *box, label)
        rois.append(Roi(label, None, box, image.shape))
    return tuple(rois)


def _mask_roi(spec: RoiSpec, shape, slice_index: int) -> Roi:
    mask = spec.mask if spec.mask.ndim == 3 else spec.mask[np.newaxis]
    if mask.shape[1:] != shape or (mask.shape[0] != 1 and slice_index >= mask.shape[0]):
        raise RoiError(
            f"ROI {spec.text!r}: mask of shape {mask.shape} does not match the image "
            f"({shape[0]} x {shape[1]} pixels, slice {slice_index})"
        )
    return Roi(spec.text, mask[0] if mask.shape[0] == 1 else mask[slice_index])


def resolve_roi(spec: RoiSpec, image: np.ndarray, spacing, slice_index: int = 0,
                found=None) -> tuple[Roi, ...]:
    """The pixel mask(s) of ``spec`` on the 2-D ``image`` (slice ``slice_index`` of its volume).

    ``spacing`` is (row, col) in mm or None; ``found`` is :func:`mri.phantom.find_phantom` of
    ``image`` when the caller has it (found here otherwise). ROIs with fewer than two pixels,
    or reaching outside the image, raise :class:`RoiError`.
    """
    shape = image.shape
    if found is None and spec.kind in ("nema5", "corners"):
        found = find_phantom(image)
    if spec.kind == "whole":
        rois = (Roi("whole", None, (0, 0, *shape), shape),)
    elif spec.kind == "box":
        _check_box(shape, *spec.box, spec.text)
        rois = (Roi(spec.text, None, spec.box, shape),)
    elif spec.kind == "central-box":
        rois = (_central_box(spec, shape, spacing),)
    elif spec.kind == "central-circle":
        rois = (_central_circle(spec, shape, spacing),)
    elif spec.kind == "phantom":
        erosion = spec.lengths[0] if spec.lengths else Length(PHANTOM_EROSION_PX, "px")
        radius = (
            erosion.pixels(spacing[0] if spacing else None, spec.text),
            erosion.pixels(spacing[1] if spacing else None, spec.text),
        )
        mask = (found or find_phantom(image))[0]
        rois = (Roi(spec.text, _eroded(mask, radius)),)
    elif spec.kind == "nema5":
        rois = _nema5(spec, image, spacing, found)
    elif spec.kind == "corners":
        rois = _corners(spec, image, spacing, found)
    else:
        rois = (_mask_roi(spec, shape, slice_index),)
    for roi in rois:
        if roi.n_pixels < 2:
            raise RoiError(f"ROI {roi.label!r} holds {roi.n_pixels} pixel(s); it needs at least 2")
    return rois
