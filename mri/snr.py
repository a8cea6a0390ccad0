"""SNR and image difference of MR acquisitions (thesis Appendix C, NEMA MS 1, McCann et al. 2013).

Pair methods estimate the noise sigma of ONE image from the difference V = a - b, whose noise
variance is twice that of a single image when a and b are independent repeats:

* ``thesis`` (eqs 91-93): SD^2 = sum (V(i, j+1) - V(i, j))^2 / (2 n (m - 1)) over the n (m - 1)
  horizontal neighbour pairs of the ROI (DESIGN section 12 corrects eq 91's denominator);
  Noise = SD / sqrt(2); SNR = S / Noise with S the mean of a. Neighbour differences cancel
  anything smooth left in V (drift, slight misregistration of smooth regions).
* ``nema`` (NEMA MS 1 subtraction): Noise = std(V in ROI) / sqrt(2); Signal = mean(a in ROI).

Single-image methods measure one image (each image of a pair separately):

* ``smoothed`` (McCann et al. 2013, the method of hazen's ``snr`` task): the image minus its
  K x K boxcar mean (K = 9 px for a head coil, 25 for a body coil) is a noise image; Noise =
  its std in the ROI, as published (no correction: for white noise it reads sigma
  sqrt(1 - 1/K^2), 0.62 % low at K = 9); Signal = mean of the image in the ROI.
* ``background`` (NEMA MS 1 single-image method): Noise = std of the air in background ROIs
  (default: four corner boxes clear of the phantom) / 0.655, the Rayleigh factor: magnitude
  noise in air has std sqrt(2 - pi/2) sigma = 0.655 sigma. It assumes one receive channel (or
  an equivalent); sum-of-squares array images and parallel imaging break it.

With several signal ROIs (e.g. ``nema5``) a slice's SNR is the mean of the ROI SNRs, as hazen
and the MATLAB scripts of McCann et al. do; signal and noise are the ROI means.

Magnitude images have Rician, not Gaussian, noise: every method overestimates a low SNR, by
1 % at SNR 8.7, 3 % at 5 and 24 % at 2 (see :func:`magnitude_snr`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import fmean

import numpy as np

from mri.errors import MeasurementError, PairMismatchError, RoiError
from mri.phantom import bounding_box
from mri.quality import QualityWarning
from mri.roi import Roi, RoiSpec, parse_roi, resolve_roi

PAIR_METHODS = ("thesis", "nema")
SINGLE_METHODS = ("smoothed", "background")
METHODS = PAIR_METHODS + SINGLE_METHODS

#: Signal ROIs each method uses when none are given: the thesis' whole image, five boxes
#: for the others; the background method's noise ROIs.
DEFAULT_ROIS = {"thesis": "whole", "nema": "nema5", "smoothed": "nema5", "background": "nema5"}
DEFAULT_BACKGROUND_ROI = "corners"

#: Boxcar of the smoothed-subtraction method (McCann et al. 2013: 9 px head coil, 25 body coil).
SMOOTHING_KERNEL_PX = 9

#: NEMA MS 1: std of magnitude noise in air over the channel sigma, sqrt(2 - pi/2) = 0.6551.
RAYLEIGH_FACTOR = 0.655

#: Reported SNR below which the Rician bias of magnitude images exceeds about 1 %
#: (magnitude_snr(s) / s = 1.01 at s = 8.7).
RICIAN_BIAS_SNR = 9.0


@dataclass(frozen=True)
class RoiMeasure:
    """One signal ROI: ``signal`` mean of the image, ``noise`` single-image sigma (pixel
    units), ``snr``, and ``dof``, the degrees of freedom of the noise estimate (see
    :func:`snr_standard_error`)."""

    roi: str
    n_pixels: int
    signal: float
    noise: float
    snr: float
    dof: float


@dataclass(frozen=True)
class MethodResult:
    """One method on one slice of one image ("a", "b") or of the pair ("a-b"): per-ROI
    measures and their means, the 95 % interval of the mean SNR (:func:`snr_interval`);
    ``noise_rois`` labels the background method's air ROIs."""

    method: str
    image: str
    rois: tuple[RoiMeasure, ...]
    signal: float
    noise: float
    snr: float
    snr_ci95: tuple[float, float]
    noise_rois: tuple[str, ...] = ()


@dataclass(frozen=True)
class SliceResult:
    """One slice: each method's result and the thesis difference, with its totals sum |a - b|
    and sum a (pixel units) from which a volume's difference is summed (None without b). A
    slice of a volume whose ROIs cannot be placed (no phantom, a box outside it) has no
    methods and says why in ``skipped``; it is left out of the summaries (its difference is
    None when sum a <= 0). ``warnings``: the slice's quality checks (:mod:`mri.quality`)."""

    index: int
    difference_percent: float | None
    methods: tuple[MethodResult, ...]
    sum_abs_difference: float | None
    sum_a: float
    skipped: str = ""
    warnings: tuple[QualityWarning, ...] = ()


@dataclass(frozen=True)
class MethodSummary:
    """One method over all measured slices (and both images for a single-image method):
    mean SNR and its 95 % interval, minimum and maximum SNR, mean signal and noise, and the
    normalised SNR (SNR x the factor of :func:`mri.normalise.normalisation_factor`) when the
    headers allow it."""

    method: str
    snr: float
    snr_ci95: tuple[float, float]
    snr_min: float
    snr_max: float
    signal: float
    noise: float
    snr_normalised: float | None = None


@dataclass(frozen=True)
class PairResult:
    """Measured images: per-slice results, per-method summaries, total difference (percent;
    None for a single image), the normalisation factor used (None if unknown) and the quality
    warnings of every slice (:mod:`mri.quality`)."""

    slices: tuple[SliceResult, ...]
    summaries: tuple[MethodSummary, ...]
    difference_percent: float | None
    normalisation_factor: float | None = None
    warnings: tuple[QualityWarning, ...] = ()

    def summary(self, method: str) -> MethodSummary:
        return next(s for s in self.summaries if s.method == method)


# --------------------------------------------------------------------------- noise estimators


def thesis_noise(diff: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Eqs 91-92: single-image noise from horizontal neighbour differences of V = a - b.

    Only neighbour pairs with both pixels in ``mask`` count (all n (m - 1) pairs of the n x m
    array ``diff`` when ``mask`` is None). Units: those of the pixels.
    """
    if mask is None:
        return _thesis_sd(_sum_squared_steps(_row_blocks(diff)), diff.shape[0] * (diff.shape[1] - 1))
    step = np.diff(diff, axis=1)
    pairs = mask[:, 1:] & mask[:, :-1]
    return _thesis_sd(float(np.sum(step[pairs] ** 2)), int(pairs.sum()))


def _thesis_sd(total: float, n_pairs: int) -> float:
    """Eqs 91-92 from the sum of the n_pairs squared neighbour differences (pixel units^2)."""
    if n_pairs == 0:
        raise MeasurementError(
            "thesis method: the ROI holds no two horizontally adjacent pixels (eq 91 needs them)"
        )
    sd = np.sqrt(total / (2.0 * n_pairs))
    return float(sd / np.sqrt(2.0))


#: Elements (float64) in a block of rows of the slice-wide sums: 64 kB blocks stay in cache
#: and reuse memory (a slice-sized temporary would be fresh pages, a page fault per 4 kB,
#: every time).
BLOCK_ELEMENTS = 8192


def _row_blocks(a: np.ndarray, b: np.ndarray | None = None):
    """Blocks of rows of the 2-D a - b in float64 (of a itself, in its own type, when ``b`` is
    None); the blocks of a difference are views of one buffer, valid until the next block."""
    rows, cols = a.shape
    block = max(1, BLOCK_ELEMENTS // cols)
    if b is not None:  # a and b are cast into two buffers (a ufunc's casting would add two)
        first, second = np.empty((min(block, rows), cols)), np.empty((min(block, rows), cols))
    for start in range(0, rows, block):
        part = a[start : start + block]
        if b is None:
            yield part
        else:
            x, y = first[: len(part)], second[: len(part)]
            np.copyto(x, part)
            np.copyto(y, b[start : start + block])
            yield np.subtract(x, y, out=x)


def _sum_squared_steps(blocks) -> float:
    """Sum over the rows i and columns j of (V[i, j + 1] - V[i, j])^2 (pixel units squared)
    of an image V given as blocks of rows (:func:`_row_blocks`)."""
    total, buffer = 0.0, None
    for part in blocks:
        rows, cols = part.shape
        if buffer is None:
            buffer = np.empty(part.size)
        if part.flags.c_contiguous:  # steps along the flat block, then the row ends left out
            flat = part.reshape(-1)
            np.subtract(flat[1:], flat[:-1], out=buffer[: part.size - 1])
            step = buffer[: part.size].reshape(rows, cols)[:, : cols - 1]
        else:
            step = np.subtract(part[:, 1:], part[:, :-1], out=buffer[: rows * (cols - 1)].reshape(rows, cols - 1))
        total += float(np.einsum("ij,ij->", step, step))
    return total


def sum_abs_difference(a: np.ndarray, b: np.ndarray) -> float:
    """sum |a - b| over a 2-D slice, in float64 (pixel units)."""
    return float(sum(np.sum(np.abs(part, out=part)) for part in _row_blocks(a, b)))


def nema_noise(diff: np.ndarray, mask: np.ndarray | None = None) -> float:
    """NEMA MS 1: sample standard deviation of V = a - b in the ROI, divided by sqrt(2)."""
    values = diff if mask is None else diff[mask]
    if values.size < 2:
        raise MeasurementError(f"NEMA method: the ROI holds {values.size} pixel(s); a standard "
                               "deviation needs at least 2")
    return float(np.std(values, ddof=1) / np.sqrt(2.0))


def smoothed_noise_image(image: np.ndarray, kernel_px: int = SMOOTHING_KERNEL_PX) -> np.ndarray:
    """McCann et al. (2013): ``image`` minus its ``kernel_px`` square boxcar mean (edges
    reflected), the noise image of the smoothed-subtraction method."""
    from scipy import ndimage

    return image - ndimage.uniform_filter(image, kernel_px, mode="reflect")


def smoothed_noise(noise_image: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Std (ddof 1) of a :func:`smoothed_noise_image` in the ROI: the noise, as published."""
    values = noise_image if mask is None else noise_image[mask]
    if values.size < 2:
        raise MeasurementError(f"smoothed method: the ROI holds {values.size} pixel(s); a "
                               "standard deviation needs at least 2")
    return float(np.std(values, ddof=1))


def background_noise(image: np.ndarray, rois: tuple[Roi, ...]) -> float:
    """NEMA MS 1 single-image noise: the RMS of the air ROIs' std (ddof 1), over the
    Rayleigh factor 0.655."""
    stds = [np.std(roi.pixels(image), ddof=1) for roi in rois]
    return float(np.sqrt(np.mean(np.square(stds))) / RAYLEIGH_FACTOR)


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
    return sum_abs_difference(a, b), float(np.sum(a, dtype=np.float64))


# --------------------------------------------------------------------------- measures


def _finite(value: float, stage: str) -> float:
    """``value``, or an error naming the stage that overflowed (pixels near 1e154 or more
    overflow float64 when squared)."""
    if not math.isfinite(value):
        raise MeasurementError(f"{stage} is {value}: the pixel values overflow float64 "
                               "arithmetic; scale the images down")
    return value


def _roi_measure(roi: Roi, signal_image: np.ndarray, noise: float, dof: float) -> RoiMeasure:
    _finite(noise, f"the noise of ROI {roi.label!r}")
    if not noise > 0.0:
        raise MeasurementError(
            f"zero noise in ROI {roi.label!r}: the noise image is constant there "
            "(identical images a and b, or a synthetic image), SNR is undefined"
        )
    signal = _finite(float(np.mean(roi.pixels(signal_image), dtype=np.float64)),
                     f"the signal of ROI {roi.label!r}")
    return RoiMeasure(roi.label, roi.n_pixels, signal, noise,
                      _finite(signal / noise, f"the SNR of ROI {roi.label!r}"), float(dof))


def measure_roi(a: np.ndarray, b: np.ndarray, roi: Roi, method: str) -> RoiMeasure:
    """Signal, noise and SNR of one ROI of the pair a, b by a pair method (eq 93: SNR = S /
    Noise). V = a - b is formed in float64 over the ROI only: a rectangle's block (by the
    thesis method a block of rows at a time), or a mask's bounding box."""
    if method not in PAIR_METHODS:
        raise MeasurementError(f"method {method!r} is not a pair method; use one of "
                               f"{', '.join(PAIR_METHODS)}")
    if roi.box is not None:
        block_a, block_b = roi.pixels(a), roi.pixels(b)
        rows, cols = block_a.shape
        if method == "thesis":
            noise = _thesis_sd(_sum_squared_steps(_row_blocks(block_a, block_b)), rows * (cols - 1))
            dof = THESIS_DOF_PER_PAIR * rows * (cols - 1)
        else:
            noise, dof = nema_noise(np.subtract(block_a, block_b, dtype=np.float64)), rows * cols - 1
    else:
        box = bounding_box(roi.mask) or (slice(0, 0), slice(0, 0))
        diff, mask = np.subtract(a[box], b[box], dtype=np.float64), roi.mask[box]
        if method == "thesis":
            noise = thesis_noise(diff, mask)
            dof = THESIS_DOF_PER_PAIR * int(np.count_nonzero(mask[:, 1:] & mask[:, :-1]))
        else:
            noise, dof = nema_noise(diff, mask), roi.n_pixels - 1
    return _roi_measure(roi, a, noise, dof)


#: Degrees of freedom per neighbour pair of the thesis noise: the consecutive differences of
#: a row share a pixel (correlation -1/2), so the sum of their squares varies as much as that
#: of 2/3 as many independent squares (variance 12 sigma^4 a pair against 8).
THESIS_DOF_PER_PAIR = 2.0 / 3.0
#: Kurtosis of the Rayleigh distribution (magnitude noise in air): the sample variance of n
#: air pixels has the relative variance (kurtosis - 1) / n, i.e. 2 n / (kurtosis - 1) degrees
#: of freedom.
RAYLEIGH_KURTOSIS = 3.245
#: Two-sided 95 % quantile of the normal distribution.
Z95 = 1.959964


def snr_standard_error(snr: float, dof: float) -> float:
    """Standard error of an SNR whose noise sigma was estimated with ``dof`` degrees of
    freedom: SNR / sqrt(2 dof) (the delta method on a chi-square variance; the error of the
    signal mean, sigma / sqrt(n), is smaller by the SNR and left out)."""
    return snr / math.sqrt(2.0 * dof)


def _interval(mean: float, standard_error: float) -> tuple[float, float]:
    return (mean - Z95 * standard_error, mean + Z95 * standard_error)


def _half_width(interval: tuple[float, float]) -> float:
    """The standard error behind a :func:`_interval`."""
    return (interval[1] - interval[0]) / (2 * Z95)


def _method_result(method, image, measures, noise_rois=()) -> MethodResult:
    """The mean of the ROIs and its 95 % interval: the ROIs' noise estimates are independent
    (their standard errors add in quadrature), except the background method's one shared
    estimate (fully correlated)."""
    snr = fmean(m.snr for m in measures)
    if noise_rois:
        error = snr_standard_error(snr, measures[0].dof)
    else:
        error = math.sqrt(sum(snr_standard_error(m.snr, m.dof) ** 2 for m in measures)) / len(measures)
    return MethodResult(
        method, image, tuple(measures),
        signal=fmean(m.signal for m in measures),
        noise=fmean(m.noise for m in measures),
        snr=snr, snr_ci95=_interval(snr, error),
        noise_rois=tuple(noise_rois),
    )


def measure_method(a: np.ndarray, b: np.ndarray, rois: tuple[Roi, ...], method: str) -> MethodResult:
    """A pair method on one slice of a and b over several ROIs: mean SNR, signal and noise of
    the ROIs."""
    if method not in PAIR_METHODS:
        raise MeasurementError(f"method {method!r} is not a pair method; use one of "
                               f"{', '.join(PAIR_METHODS)}")
    return _method_result(method, "a-b", [measure_roi(a, b, roi, method) for roi in rois])


def measure_single(image: np.ndarray, name: str, rois: tuple[Roi, ...], method: str,
                   background_rois: tuple[Roi, ...] = (),
                   kernel_px: int = SMOOTHING_KERNEL_PX) -> MethodResult:
    """A single-image method (``smoothed`` or ``background``) on one slice of image ``name``
    (measured in float64)."""
    image = image.astype(np.float64, copy=False)
    if method == "smoothed":
        noise_image = smoothed_noise_image(image, kernel_px)
        measures = [_roi_measure(roi, image, smoothed_noise(roi.pixels(noise_image)), roi.n_pixels - 1)
                    for roi in rois]
        return _method_result(method, name, measures)
    if method == "background":
        if not background_rois:
            raise MeasurementError("background method: no background (air) ROI given")
        noise = background_noise(image, background_rois)
        dof = 2.0 * sum(roi.n_pixels for roi in background_rois) / (RAYLEIGH_KURTOSIS - 1.0)
        return _method_result(method, name, [_roi_measure(roi, image, noise, dof) for roi in rois],
                              [roi.label for roi in background_rois])
    raise MeasurementError(f"method {method!r} is not a single-image method; use one of "
                           f"{', '.join(SINGLE_METHODS)}")


def measure_slice(
    index: int, a: np.ndarray, b: np.ndarray | None, rois_by_method: dict[str, tuple[Roi, ...]],
    background_rois: tuple[Roi, ...] = (), kernel_px: int = SMOOTHING_KERNEL_PX,
) -> SliceResult:
    """All requested methods on one 2-D slice (pair, or a alone when ``b`` is None), measured
    in float64 whatever the pixels' float type; ``rois_by_method``: method -> signal ROIs.
    The difference a - b is formed per ROI and a block of rows at a time, never as a whole
    slice (a fresh slice-sized temporary costs a page fault per 4 kB)."""
    results = []
    for method, rois in rois_by_method.items():
        if method in PAIR_METHODS:
            if b is None:
                raise MeasurementError(f"method {method!r} needs a pair of images a and b; "
                                       f"one image takes {' or '.join(SINGLE_METHODS)}")
            results.append(measure_method(a, b, rois, method))
        else:
            for name, image in (("a", a), ("b", b)):
                if image is not None:
                    results.append(measure_single(image, name, rois, method, background_rois, kernel_px))
    sum_a = _finite(float(np.sum(a, dtype=np.float64)), f"slice {index}: sum a")
    if b is None:
        return SliceResult(index, None, tuple(results), None, sum_a)
    total = _finite(sum_abs_difference(a, b), f"slice {index}: sum |a - b|")
    return SliceResult(index, _percent(total, sum_a), tuple(results), total, sum_a)


def summarise(slices: tuple[SliceResult, ...], normalisation_factor: float | None = None) -> PairResult:
    """Per-method summaries over the measured slices (both images for a single-image method)
    and the total difference of the whole volume (every slice); an error when no slice was
    measured. ``normalisation_factor`` (see :mod:`mri.normalise`) gives ``snr_normalised``."""
    measured = [s for s in slices if not s.skipped]
    if not measured:
        reasons = "; ".join(f"slice {s.index}: {s.skipped}" for s in slices[:3])
        raise MeasurementError(f"no slice of the {len(slices)} could be measured ({reasons}"
                               f"{'; ...' if len(slices) > 3 else ''})")
    summaries = []
    for method in dict.fromkeys(m.method for m in measured[0].methods):
        results = [m for s in measured for m in s.methods if m.method == method]
        snrs = [m.snr for m in results]
        mean = fmean(snrs)
        error = math.sqrt(sum(_half_width(m.snr_ci95) ** 2 for m in results)) / len(results)
        summaries.append(
            MethodSummary(
                method,
                snr=mean,
                snr_ci95=_interval(mean, error),
                snr_min=min(snrs),
                snr_max=max(snrs),
                signal=fmean(m.signal for m in results),
                noise=fmean(m.noise for m in results),
                snr_normalised=None if normalisation_factor is None else mean * normalisation_factor,
            )
        )
    if slices[0].sum_abs_difference is None:
        total = None
    else:
        total = _finite(_percent(sum(s.sum_abs_difference for s in slices),
                                 sum(s.sum_a for s in slices)), "the total difference")
    return PairResult(slices, tuple(summaries), total, normalisation_factor, _volume_warnings(slices))


def _volume_warnings(slices: tuple[SliceResult, ...]) -> tuple[QualityWarning, ...]:
    """The slices' warnings: all of a single slice's; of a volume, the first of each kind
    (code, method, image), naming its slice and how many slices had it."""
    if len(slices) == 1:
        return slices[0].warnings
    first, counts = {}, {}
    for s in slices:
        for w in s.warnings:
            key = (w.code, w.values.get("method"), w.values.get("image"))
            counts[key] = counts.get(key, 0) + 1
            first.setdefault(key, (s.index, w))
    out = []
    for key, (index, w) in first.items():
        more = counts[key] - 1
        out.append(QualityWarning(w.code, f"slice {index}{f' (and {more} more)' if more else ''}: "
                                          f"{w.message}",
                                  {**w.values, "slice": index, "slices_affected": counts[key]}))
    return tuple(out)


#: ROI kinds that need the phantom found on the slice.
_PHANTOM_KINDS = ("phantom", "nema5", "corners")


def measure_arrays(
    a: np.ndarray, b: np.ndarray | None, spacing_mm, specs_by_method: dict[str, tuple[RoiSpec, ...]],
    background_specs: tuple[RoiSpec, ...] | None = None, kernel_px: int = SMOOTHING_KERNEL_PX,
    normalisation_factor: float | None = None,
) -> PairResult:
    """Measure a (slices, rows, cols) pair (or image a alone, ``b`` None) slice by slice, in
    float64; ROIs are resolved on each slice of a, and the phantom is found once per slice.

    ``spacing_mm`` is (row, col) in mm or None; ``specs_by_method`` maps each method to its
    signal ROI specs; ``background_specs`` are the background method's air ROIs (default
    ``corners``). A single slice whose ROIs or measures fail raises; in a volume such a slice
    is skipped with its reason (:class:`SliceResult`) and the others are measured.
    """
    if b is not None and a.shape != b.shape:
        raise MeasurementError(f"pair shapes differ: {a.shape} and {b.shape}")
    if background_specs is None:
        background_specs = (parse_roi(DEFAULT_BACKGROUND_ROI),) if "background" in specs_by_method else ()
    all_specs = [spec for specs in specs_by_method.values() for spec in specs] + list(background_specs)
    needs_phantom = any(spec.kind in _PHANTOM_KINDS for spec in all_specs)
    with np.errstate(over="ignore", invalid="ignore"):  # overflow is checked, not warned
        slices = [_measure_slice_or_skip(k, a, b, spacing_mm, specs_by_method, background_specs,
                                         kernel_px, needs_phantom)
                  for k in range(a.shape[0])]
    return summarise(tuple(slices), normalisation_factor)


def _measure_slice_or_skip(k, a, b, spacing_mm, specs_by_method, background_specs, kernel_px,
                           needs_phantom) -> SliceResult:
    """Slice ``k`` measured, or (in a volume) skipped with the reason its ROIs or measures
    failed; pixels are read as they are (float32 or float64) and measured in float64."""
    import dataclasses

    from mri.phantom import find_phantom, phantom_centroid
    from mri.quality import check_same_object, outlier_box_warnings, phantom_warnings, registration_warnings

    a_k, b_k = a[k], None if b is None else b[k]
    try:
        found = find_phantom(a_k) if needs_phantom else None
        warnings = []
        if found is not None:
            if b_k is not None:
                check_same_object(found[1], phantom_centroid(b_k, found[1].centre_px))
            warnings += phantom_warnings(found[1])

        def resolve(specs):
            return tuple(roi for spec in specs for roi in resolve_roi(spec, a_k, spacing_mm, k, found))

        rois = {method: resolve(specs) for method, specs in specs_by_method.items()}
        for note in (roi.note for group in rois.values() for roi in group if roi.note):
            if note not in warnings:
                warnings.append(note)
        result = measure_slice(k, a_k, b_k, rois, resolve(background_specs), kernel_px)
        warnings += [w for m in result.methods for w in outlier_box_warnings(m)]
        if b_k is not None and k == a.shape[0] // 2:
            # shift and gain of b on one slice (the middle one of a volume: a moved phantom or
            # a gain change shows on every slice, and the fit costs a millisecond a slice)
            warnings += registration_warnings(a_k, b_k)
        return dataclasses.replace(result, warnings=tuple(warnings))
    except (RoiError, MeasurementError, PairMismatchError) as exc:
        if a.shape[0] == 1:
            raise
        if b_k is None:
            return SliceResult(k, None, (), None, float(np.sum(a_k, dtype=np.float64)), skipped=str(exc))
        diff_sum, a_sum = _sums(a_k, b_k)
        return SliceResult(k, 100.0 * diff_sum / a_sum if a_sum > 0 else None,
                           (), diff_sum, a_sum, skipped=str(exc))


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
