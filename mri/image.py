"""The image model shared by the loaders and the measures: pixels plus the metadata that matters.

Pixels are always a float array of shape ``(slices, rows, cols)``; a 2-D image is one slice. They
are float32 when that is exact (8- and 16-bit integers, float32 input: half the memory of a
large volume) and float64 otherwise; the measures work in float64 slice by slice.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mri.errors import ImageLoadError


@dataclass(frozen=True, eq=False)
class MriImage:
    """One image or volume and its metadata.

    ``pixel_spacing_mm`` is (row spacing, column spacing) in mm, ``orientation`` the six DICOM
    direction cosines of rows and columns, ``position_mm`` the patient position of the first
    slice's first pixel; ``series`` the series description; ``acquisition`` holds protocol fields (TR/TE in ms, flip angle in
    degrees, bandwidth in Hz/pixel, ...) that must agree between the two images of a pair.
    Unknown metadata is ``None`` (PNG, TIFF and NPY carry none).
    """

    pixels: np.ndarray
    source: str
    format: str
    pixel_spacing_mm: tuple[float, float] | None = None
    slice_thickness_mm: float | None = None
    orientation: tuple[float, ...] | None = None
    position_mm: tuple[float, float, float] | None = None
    series: str | None = None
    series_number: int | None = None
    scanner: str | None = None
    acquisition: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int, int]:
        """(slices, rows, cols)."""
        return self.pixels.shape

    @property
    def n_slices(self) -> int:
        return self.pixels.shape[0]


def as_pixels(array, source: str) -> np.ndarray:
    """Validate a 2-D or 3-D real numeric array and return it as float (slices, rows, cols).

    Raises :class:`ImageLoadError` naming ``source`` for other dimensions, complex or non-numeric
    data, images smaller than 2 x 2, and NaN or infinite pixels.
    """
    arr = np.asarray(array)
    if arr.dtype.kind == "c":
        raise ImageLoadError(f"{source}: complex pixel data; pass magnitude images")
    if arr.dtype.kind not in "biuf":
        raise ImageLoadError(f"{source}: pixel data of type {arr.dtype} is not numeric")
    if arr.ndim == 2:
        arr = arr[np.newaxis]
    if arr.ndim != 3:
        raise ImageLoadError(
            f"{source}: image has {arr.ndim} dimensions {arr.shape}; expected 2 (rows, cols) "
            "or 3 (slices, rows, cols)"
        )
    if arr.shape[0] < 1 or arr.shape[1] < 2 or arr.shape[2] < 2:
        raise ImageLoadError(f"{source}: image of shape {arr.shape} is too small (need 2 x 2)")
    exact32 = arr.dtype == np.float32 or (arr.dtype.kind in "biu" and arr.dtype.itemsize <= 2)
    out = arr.astype(np.float32 if exact32 else np.float64, copy=False)
    bad = ~np.isfinite(out) if arr.dtype.kind == "f" else None  # integers are always finite
    if bad is not None and bad.any():
        raise ImageLoadError(
            f"{source}: {int(bad.sum())} pixel(s) are NaN or infinite; pixels must be finite"
        )
    return out
