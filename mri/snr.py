"""SNR and image difference from a pair of repeated MR acquisitions (thesis Appendix C).

Both methods estimate the noise sigma of ONE image from the difference V = a - b, whose noise
variance is twice that of a single image when a and b are independent repeats:

* thesis (eqs 91-93): SD^2 = sum (V(i, j+1) - V(i, j))^2 / (2 n (m - 1)) over the n (m - 1)
  horizontal neighbour pairs of the ROI (DESIGN section 12 corrects eq 91's denominator);
  Noise = SD / sqrt(2); SNR = S / Noise with S the mean of a. Neighbour differences cancel
  anything smooth left in V (drift, slight misregistration of smooth regions).
* NEMA MS 1 subtraction: Noise = std(V in ROI) / sqrt(2); Signal = mean(a in ROI).

With several ROIs (e.g. ``nema5``) the slice's SNR is the mean of the ROI SNRs, as hazen and
the MATLAB scripts of McCann et al. (2013) do; signal and noise are the ROI means.

Magnitude images have Rician, not Gaussian, noise: both methods overestimate a low SNR, by
1 % at SNR 8.7, 3 % at 5 and 24 % at 2 (see :func:`magnitude_snr`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mri.errors import MeasurementError, RoiError
from mri.roi import Roi, RoiSpec, resolve_roi

METHODS = ("thesis", "nema")

#: ROIs each method uses when none are given: the thesis' whole image, NEMA's five boxes.
DEFAULT_ROIS = {"thesis": "whole", "nema": "nema5"}

#: Reported SNR below which the Rician bias of magnitude images exceeds about 1 %
#: (magnitude_snr(s) / s = 1.01 at s = 8.7).
RICIAN_BIAS_SNR = 9.0


@dataclass(frozen=True)
class RoiMeasure:
    """One ROI: ``signal`` mean of a, ``noise`` single-image sigma (pixel units), ``snr``."""

    roi: str
    n_pixels: int
    signal: float
    noise: float
    snr: float


@dataclass(frozen=True)
class MethodResult:
    """One method on one slice: per-ROI measures and their means."""

    method: str
    rois: tuple[RoiMeasure, ...]
    signal: float
    noise: float
    snr: float


@dataclass(frozen=True)
class SliceResult:
    """One slice: each method's result and the thesis difference, with its totals sum |a - b|
    and sum a (pixel units) from which a volume's difference is summed. A slice of a volume
    whose ROIs cannot be placed (no phantom, a box outside it) has no methods and says why in
    ``skipped``; it is left out of the summaries (its difference is None when sum a <= 0)."""

    index: int
    difference_percent: float | None
    methods: tuple[MethodResult, ...]
    sum_abs_difference: float
    sum_a: float
    skipped: str = ""


@dataclass(frozen=True)
class MethodSummary:
    """One method over all slices: mean, minimum and maximum SNR, mean signal and noise."""

    method: str
    snr: float
    snr_min: float
    snr_max: float
    signal: float
    noise: float


@dataclass(frozen=True)
class PairResult:
    """A measured pair: per-slice results, per-method summaries, total difference (percent)."""

    slices: tuple[SliceResult, ...]
    summaries: tuple[MethodSummary, ...]
    difference_percent: float

    def summary(self, method: str) -> MethodSummary:
        return next(s for s in self.summaries if s.method == method)


# --------------------------------------------------------------------------- noise estimators


def thesis_noise(diff: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Eqs 91-92: single-image noise from horizontal neighbour differences of V = a - b.

    Only neighbour pairs with both pixels in ``mask`` count (all n (m - 1) pairs of the n x m
    array ``diff`` when ``mask`` is None). Units: those of the pixels.
    """
    step = np.diff(diff, axis=1)
    if mask is None:
        n_pairs, total = step.size, float(np.einsum("ij,ij->", step, step))
    else:
        pairs = mask[:, 1:] & mask[:, :-1]
        n_pairs, total = int(pairs.sum()), float(np.sum(step[pairs] ** 2))
    if n_pairs == 0:
        raise MeasurementError(
            "thesis method: the ROI holds no two horizontally adjacent pixels (eq 91 needs them)"
        )
    sd = np.sqrt(total / (2.0 * n_pairs))
    return float(sd / np.sqrt(2.0))


def nema_noise(diff: np.ndarray, mask: np.ndarray | None = None) -> float:
    """NEMA MS 1: sample standard deviation of V = a - b in the ROI, divided by sqrt(2)."""
    values = diff if mask is None else diff[mask]
    if values.size < 2:
        raise MeasurementError(f"NEMA method: the ROI holds {values.size} pixel(s); a standard "
                               "deviation needs at least 2")
    return float(np.std(values, ddof=1) / np.sqrt(2.0))


_NOISE = {"thesis": thesis_noise, "nema": nema_noise}


def _percent(sum_abs_difference: float, sum_a: float) -> float:
    if sum_a <= 0:
        raise MeasurementError(
            f"difference: the pixels of a sum to {sum_a:g}; the thesis' difference needs a "
            "positive total"
        )
    return 100.0 * sum_abs_difference / sum_a


def difference_percent(a: np.ndarray, b: np.ndarray) -> float:
    """The thesis' difference (Figures 57, 58, 60): 100 * sum |a - b| / sum a.

    Volumes are summed slice by slice, so no volume-sized temporary is made.
    """
    if a.ndim == 3:
        sums = np.array([_sums(x, y) for x, y in zip(a, b)])
        return _percent(float(sums[:, 0].sum()), float(sums[:, 1].sum()))
    return _percent(*_sums(a, b))


def _sums(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """sum |a - b| and sum a of one slice, in float64."""
    a = a.astype(np.float64, copy=False)
    return float(np.sum(np.abs(a - b))), float(np.sum(a))


# --------------------------------------------------------------------------- measures


def measure_roi(a: np.ndarray, diff: np.ndarray, roi: Roi, method: str) -> RoiMeasure:
    """Signal, noise and SNR of one ROI on one slice (eq 93: SNR = S / Noise)."""
    if roi.box is None:
        noise = _NOISE[method](diff, roi.mask)
    else:  # a rectangle: measure on the block itself, no mask needed
        noise = _NOISE[method](roi.pixels(diff))
    if noise == 0.0:
        raise MeasurementError(
            f"zero noise in ROI {roi.label!r}: images a and b are identical there, SNR is undefined"
        )
    signal = float(np.mean(roi.pixels(a)))
    return RoiMeasure(roi.label, roi.n_pixels, signal, noise, signal / noise)


def measure_method(a: np.ndarray, diff: np.ndarray, rois: tuple[Roi, ...], method: str) -> MethodResult:
    """One method on one slice over several ROIs: mean SNR, signal and noise of the ROIs."""
    if method not in _NOISE:
        raise MeasurementError(f"method {method!r} unknown; use one of {', '.join(METHODS)}")
    measures = tuple(measure_roi(a, diff, roi, method) for roi in rois)
    return MethodResult(
        method,
        measures,
        signal=float(np.mean([m.signal for m in measures])),
        noise=float(np.mean([m.noise for m in measures])),
        snr=float(np.mean([m.snr for m in measures])),
    )


def measure_slice(
    index: int, a: np.ndarray, b: np.ndarray, rois_by_method: dict[str, tuple[Roi, ...]]
) -> SliceResult:
    """All requested methods on one 2-D float64 slice pair; ``rois_by_method``: method -> ROIs."""
    diff = a - b
    sum_abs_difference, sum_a = float(np.sum(np.abs(diff))), float(np.sum(a))
    return SliceResult(
        index,
        _percent(sum_abs_difference, sum_a),
        tuple(measure_method(a, diff, rois, m) for m, rois in rois_by_method.items()),
        sum_abs_difference,
        sum_a,
    )


def summarise(slices: tuple[SliceResult, ...]) -> PairResult:
    """Per-method summaries over the measured slices and the total difference of the whole
    volume (every slice); an error when no slice was measured."""
    measured = [s for s in slices if not s.skipped]
    if not measured:
        reasons = "; ".join(f"slice {s.index}: {s.skipped}" for s in slices[:3])
        raise MeasurementError(f"no slice of the {len(slices)} could be measured ({reasons}"
                               f"{'; ...' if len(slices) > 3 else ''})")
    summaries = []
    for k, result in enumerate(measured[0].methods):
        per_slice = [s.methods[k] for s in measured]
        snrs = [m.snr for m in per_slice]
        summaries.append(
            MethodSummary(
                result.method,
                snr=float(np.mean(snrs)),
                snr_min=float(np.min(snrs)),
                snr_max=float(np.max(snrs)),
                signal=float(np.mean([m.signal for m in per_slice])),
                noise=float(np.mean([m.noise for m in per_slice])),
            )
        )
    total = _percent(sum(s.sum_abs_difference for s in slices), sum(s.sum_a for s in slices))
    return PairResult(slices, tuple(summaries), total)


def measure_pair(
    a: np.ndarray, b: np.ndarray, spacing_mm, specs_by_method: dict[str, tuple[RoiSpec, ...]]
) -> PairResult:
    """Measure a (slices, rows, cols) pair slice by slice, in float64; ROIs are resolved on each
    slice of a.

    ``spacing_mm`` is (row, col) in mm or None; ``specs_by_method`` maps each method to measure
    to its ROI specs. A single slice whose ROIs or measures fail raises; in a volume such a
    slice is skipped with its reason (:class:`SliceResult`) and the others are measured.
    """
    if a.shape != b.shape:
        raise MeasurementError(f"pair shapes differ: {a.shape} and {b.shape}")
    slices = []
    for k in range(a.shape[0]):
        a_k, b_k = a[k].astype(np.float64), b[k].astype(np.float64)
        try:
            rois = {
                method: tuple(roi for spec in specs for roi in resolve_roi(spec, a_k, spacing_mm, k))
                for method, specs in specs_by_method.items()
            }
            slices.append(measure_slice(k, a_k, b_k, rois))
        except (RoiError, MeasurementError) as exc:
            if a.shape[0] == 1:
                raise
            diff_sum, a_sum = _sums(a_k, b_k)
            slices.append(SliceResult(k, 100.0 * diff_sum / a_sum if a_sum > 0 else None,
                                      (), diff_sum, a_sum, skipped=str(exc)))
    return summarise(tuple(slices))


def magnitude_snr(true_snr: float) -> float:
    """SNR that either method reports for a magnitude (Rician) pair of true SNR ``true_snr``.

    A magnitude pixel |A + n1 + i n2| (n1, n2 Gaussian of sigma) has a Rice distribution; the
    methods measure its mean over its standard deviation, E[M] / std(M), not A / sigma. Ratio
    reported/true: 2.00 at SNR 1, 1.24 at 2, 1.05 at 4, 1.03 at 5, 1.01 at 8.7, 1.002 at 20
    (the Rice distribution tends to a Gaussian); pure noise (SNR 0) reports 1.91.
    """
    from scipy.special import i0e, i1e

    if true_snr < 0:
        raise MeasurementError(f"true_snr = {true_snr} must be >= 0")
    # Rice moments for sigma = 1: E[M] = sqrt(pi/2) L_1/2(x), x = -A^2/2, with the Laguerre
    # function L_1/2(x) = exp(x/2) [(1 - x) I0(-x/2) - x I1(-x/2)] written with exponentially
    # scaled Bessel functions (no overflow at high SNR); E[M^2] = 2 + A^2.
    x = -0.5 * true_snr**2
    mean = np.sqrt(np.pi / 2) * ((1 - x) * i0e(-x / 2) - x * i1e(-x / 2))
    return float(mean / np.sqrt(2.0 + true_snr**2 - mean**2))
