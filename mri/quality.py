"""Quality checks of a measured pair: warnings with machine-readable codes wherever an SNR
cannot be trusted as it stands.

Each :class:`QualityWarning` has a ``code`` (one of :data:`CODES`), a one-line ``message``
and the ``values`` it was decided on. The checks and their limits:

* ``misregistration``: the shift of b against a fitted to a - b (:mod:`mri.registration`)
  exceeds MAX_SHIFT_PX. A shifted edge leaks into the noise of every ROI that reaches it,
  and into the thesis method's whole-image noise at once (a 3 px shift of the Aera pair
  reads its thesis SNR 12 times low);
* ``gain_change``: the fitted gain of b over a exceeds MAX_GAIN_PERCENT: the difference
  then holds a copy of the image (SNR reads low wherever the signal is high);
* ``outlier_box``: a ROI's SNR differs from the median ROI's by more than OUTLIER_FACTOR
  (an insert, an artefact, or shading strong enough to make the mean of the boxes a mix);
* ``low_inlier_fraction``: fewer than MIN_INLIER_FRACTION of the phantom's outline points
  lie on the fitted shape: the outline is not the phantom's (shading below the noise, a
  phantom cut by the field of view), so the centre and the boxes are doubtful;
* ``centroid_disagreement``: the centroid of the phantom mask lies more than MAX_CENTRE_PX
  from the fitted centre (an object that is not one disc or rectangle, or a mask cut short);
* ``boxes_shrunk``: the default NEMA boxes did not fit and a smaller layout was used;
* ``header_differs``, ``rician_bias``, ``slices_skipped``, ``normalisation_missing``: the
  pair's descriptive headers differ, the SNR is low enough for magnitude noise to bias it,
  slices of a volume could not be measured, the header lacks a normalisation input.

The limits were set on hazen's 13-pair corpus (tests/data/mri): its pairs read shifts up to
0.15 px, gains up to 0.5 %, box SNRs up to x1.45 from the median (the Aera's centre box,
under a head array's darker centre), inlier fractions down to 0.67 (the Philips phantom's
distorted rectangle); a rotated rectangle (the Vida pair, 0.46) is flagged.
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: Limits of the checks (see the module).
MAX_SHIFT_PX = 0.3
MAX_GAIN_PERCENT = 2.0
OUTLIER_FACTOR = 1.5
MIN_INLIER_FRACTION = 0.6
MAX_CENTRE_PX = 2.0

CODES = ("misregistration", "gain_change", "outlier_box", "low_inlier_fraction",
         "centroid_disagreement", "boxes_shrunk", "header_differs", "rician_bias",
         "slices_skipped", "normalisation_missing")


@dataclass(frozen=True)
class QualityWarning:
    """A warning: ``code`` (one of :data:`CODES`), a one-line ``message`` and the numbers it
    was decided on (``values``, JSON-ready)."""

    code: str
    message: str
    values: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.code not in CODES:
            raise ValueError(f"warning code {self.code!r} unknown; use one of {', '.join(CODES)}")

    def __str__(self) -> str:
        return f"[{self.code}] {self.message}"


#: Largest distance (pixels) between the centroids of the phantom masks found in a and in b
#: for the two to be the same object; beyond it the pair is refused (a moved phantom, another
#: bottle). Centroids, not the fitted centres: a doubtful fit (flagged by the checks below)
#: must not pass for a moved object.
SAME_OBJECT_PX = 5.0


def check_same_object(fit_a, centroid_b) -> None:
    """Refuse a pair whose phantoms are not the same object: the mask centroids of a
    (:class:`mri.phantom.PhantomFit`) and of b (:func:`mri.phantom.phantom_centroid`) more
    than SAME_OBJECT_PX apart."""
    from mri.errors import PairMismatchError

    distance = _distance(fit_a.centroid_px, centroid_b)
    if distance > SAME_OBJECT_PX:
        raise PairMismatchError(
            f"the phantom found in a (centroid row, col {_point(fit_a.centroid_px)}) and in b "
            f"({_point(centroid_b)}) are {distance:.1f} px apart (limit {SAME_OBJECT_PX:g}): "
            "not the same object; check that the images are a repeated acquisition"
        )


def _distance(p, q) -> float:
    return float(((p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2) ** 0.5)


def _point(p) -> str:
    return f"{p[0]:.1f}, {p[1]:.1f}"


def phantom_warnings(fit) -> list[QualityWarning]:
    """``low_inlier_fraction`` and ``centroid_disagreement`` of a phantom fit."""
    warnings = []
    if fit.inlier_fraction < MIN_INLIER_FRACTION:
        warnings.append(QualityWarning(
            "low_inlier_fraction",
            f"only {100 * fit.inlier_fraction:.0f} % of the phantom's outline lies on the fitted "
            f"{fit.shape} (limit {100 * MIN_INLIER_FRACTION:.0f} %): the outline found is not the "
            "phantom's whole edge, so its centre and the boxes are doubtful",
            {"inlier_fraction": fit.inlier_fraction, "limit": MIN_INLIER_FRACTION}))
    distance = _distance(fit.centre_px, fit.centroid_px)
    if distance > MAX_CENTRE_PX:
        warnings.append(QualityWarning(
            "centroid_disagreement",
            f"the phantom mask's centroid (row, col {_point(fit.centroid_px)}) is {distance:.1f} px "
            f"from the fitted {fit.shape} centre ({_point(fit.centre_px)}; limit {MAX_CENTRE_PX:g} px)",
            {"centroid_px": list(fit.centroid_px), "centre_px": list(fit.centre_px),
             "distance_px": distance, "limit_px": MAX_CENTRE_PX}))
    return warnings


def outlier_box_warnings(method_result) -> list[QualityWarning]:
    """``outlier_box``: ROIs of a method (three or more) whose SNR is more than OUTLIER_FACTOR
    above or below the median ROI's."""
    rois = method_result.rois
    if len(rois) < 3:
        return []
    snrs = sorted(r.snr for r in rois)
    median = snrs[len(snrs) // 2] if len(snrs) % 2 else (snrs[len(snrs) // 2 - 1] + snrs[len(snrs) // 2]) / 2
    out = [r for r in rois if median > 0 and max(r.snr / median, median / r.snr) > OUTLIER_FACTOR]
    if not out:
        return []
    listed = ", ".join(f"{r.roi} {r.snr:.1f}" for r in out)
    return [QualityWarning(
        "outlier_box",
        f"{method_result.method} ({method_result.image}): ROI SNR differs from the median ROI's "
        f"{median:.1f} by more than x{OUTLIER_FACTOR:g}: {listed} (an insert, an artefact or "
        "strong shading; the mean of the ROIs mixes them)",
        {"method": method_result.method, "image": method_result.image, "median_snr": median,
         "factor": OUTLIER_FACTOR, "rois": {r.roi: r.snr for r in out}})]


def registration_warnings(a, b) -> list[QualityWarning]:
    """``misregistration`` and ``gain_change`` of b against a (2-D slices), fitted to a - b
    (:func:`mri.registration.shift_and_gain`)."""
    from mri.registration import shift_and_gain

    gain, shift_row, shift_col, _ = shift_and_gain(a, b)
    warnings = []
    shift = max(abs(shift_row), abs(shift_col))
    if shift > MAX_SHIFT_PX:
        warnings.append(QualityWarning(
            "misregistration",
            f"b is shifted against a by {shift_row:+.2f} px (rows) and "
            f"{shift_col:+.2f} px (columns), fitted to a - b (limit {MAX_SHIFT_PX:g} px; a "
            "first-order fit: shifts of pixels are read roughly): the phantom moved or the "
            "frequency drifted, "
            "and the shifted edge enters the noise of every ROI near it",
            {"shift_row_px": shift_row, "shift_col_px": shift_col, "limit_px": MAX_SHIFT_PX}))
    if abs(100 * gain) > MAX_GAIN_PERCENT:
        warnings.append(QualityWarning(
            "gain_change",
            f"b's intensity differs from a's by {100 * gain:+.1f} %, fitted to a - b (limit "
            f"{MAX_GAIN_PERCENT:g} %): the receiver gain or the scanner changed between the "
            "acquisitions, and a - b holds a copy of the image",
            {"gain_percent": 100 * gain, "limit_percent": MAX_GAIN_PERCENT}))
    return warnings
