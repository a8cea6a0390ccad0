"""Check that two images can be compared pixel by pixel (NEMA MS 1 needs a repeated acquisition).

:func:`check_pair` raises :class:`mri.errors.PairMismatchError` for differences that make a
difference image meaningless (shape, pixel spacing, slice thickness, orientation, position,
protocol) and returns warnings, each naming its field, for differences that are only
descriptive (series description, scanner name, coil name, spacing known for one image only).
"""

from __future__ import annotations

import math

from mri.errors import PairMismatchError
from mri.image import MriImage
from mri.io import DICOM_ACQUISITION_FIELDS, DICOM_DESCRIPTIVE_FIELDS

#: Relative tolerance on spacing and protocol numbers (DICOM decimal strings round-trip).
REL_TOL = 1e-4
#: Absolute tolerance on direction cosines (dimensionless) and positions (mm).
COSINE_TOL = 1e-4
POSITION_TOL_MM = 0.01


def _close(x, y, rel=REL_TOL, abs_tol=0.0) -> bool:
    if isinstance(x, float) and isinstance(y, float):
        return math.isclose(x, y, rel_tol=rel, abs_tol=abs_tol)
    return x == y


def _close_seq(x, y, abs_tol: float) -> bool:
    return len(x) == len(y) and all(math.isclose(u, v, abs_tol=abs_tol) for u, v in zip(x, y))


def _fmt(value) -> str:
    return "unknown" if value is None else str(value)


def check_pair(a: MriImage, b: MriImage, names: tuple[str, str] = ("a", "b")) -> tuple[str, ...]:
    """Raise if ``a`` and ``b`` cannot be compared; return warnings for harmless differences."""
    na, nb = names
    if a.shape != b.shape:
        raise PairMismatchError(
            f"image shapes differ: {na} is {_shape(a)}, {nb} is {_shape(b)}; "
            "a pair must have the same size"
        )
    warnings = []
    _check_number_pair(
        "pixel spacing (mm)", a.pixel_spacing_mm, b.pixel_spacing_mm, names, warnings, seq=True
    )
    _check_number_pair(
        "slice thickness (mm)", a.slice_thickness_mm, b.slice_thickness_mm, names, warnings
    )
    if a.orientation and b.orientation and not _close_seq(a.orientation, b.orientation, COSINE_TOL):
        raise PairMismatchError(
            f"image orientation differs: {na} {a.orientation}, {nb} {b.orientation}; "
            "the images must be the same slice"
        )
    if a.position_mm and b.position_mm and not _close_seq(a.position_mm, b.position_mm, POSITION_TOL_MM):
        raise PairMismatchError(
            f"image position (mm) differs: {na} {a.position_mm}, {nb} {b.position_mm}; "
            "the images must be the same slice"
        )
    for field in DICOM_ACQUISITION_FIELDS:
        va, vb = a.acquisition.get(field), b.acquisition.get(field)
        if va is not None and vb is not None and not _close(va, vb):
            raise PairMismatchError(
                f"acquisition parameter {field} differs: {na} {va}, {nb} {vb}; "
                "a pair must use the same protocol"
            )
    for field, va, vb in [("series", a.series, b.series),
                          ("scanner", a.scanner, b.scanner)] + [
        (f, a.acquisition.get(f), b.acquisition.get(f)) for f in DICOM_DESCRIPTIVE_FIELDS
    ]:
        if va is not None and vb is not None and va != vb:
            warnings.append(f"{field} differs: {na} {va!r}, {nb} {vb!r}")
    return tuple(warnings)


def _shape(img: MriImage) -> str:
    s, r, c = img.shape
    return f"{r} x {c}" if s == 1 else f"{s} x {r} x {c} (slices x rows x cols)"


def _check_number_pair(label, va, vb, names, warnings, seq=False) -> None:
    """Error when both values are known and differ; warning when only one is known."""
    na, nb = names
    if va is None and vb is None:
        return
    if va is None or vb is None:
        warnings.append(f"{label} known only for {nb if va is None else na}: {_fmt(va or vb)}")
        return
    same = all(_close(float(x), float(y)) for x, y in zip(va, vb)) if seq else _close(float(va), float(vb))
    if not same:
        raise PairMismatchError(f"{label} differs: {na} {va}, {nb} {vb}; a pair must match")
