"""From files to results: load one image or a pair, check it, measure it with every requested
method, and shape the results for text, JSON, CSV, figures and reports (used by ``dacm snr``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from mri.errors import MriError, RoiError
from mri.figure import PairPanel
from mri.image import MriImage
from mri.io import load_image
from mri.normalise import normalisation_factor, normalisation_inputs
from mri.pair import check_pair
from mri.quality import QualityWarning
from mri.roi import Roi, parse_roi, resolve_roi
from mri.snr import (
    DEFAULT_BACKGROUND_ROI,
    DEFAULT_ROIS,
    PAIR_METHODS,
    RICIAN_BIAS_SNR,
    SINGLE_METHODS,
    SMOOTHING_KERNEL_PX,
    PairResult,
    measure_arrays,
)


@dataclass(frozen=True)
class SnrOptions:
    """What to measure: ``methods`` (None: thesis and nema for a pair, smoothed for one
    image), signal ROI texts (None: each method's default), background ROI texts, the
    smoothing kernel (px) and normalisation overrides (field -> value)."""

    methods: tuple[str, ...] | None = None
    rois: tuple[str, ...] = ()
    background_rois: tuple[str, ...] = ()
    kernel_px: int = SMOOTHING_KERNEL_PX
    normalisation: dict = field(default_factory=dict)

    def __post_init__(self):
        if isinstance(self.kernel_px, bool) or not isinstance(self.kernel_px, int) or not 3 <= self.kernel_px <= 101:
            raise MriError(f"kernel_px = {self.kernel_px!r}: the smoothing kernel must be a whole "
                           "number of pixels from 3 to 101")


@dataclass(frozen=True, eq=False)
class MeasuredPair:
    """Loaded, checked and measured images (``b`` None for one image) with their ROI specs,
    quality warnings (:class:`mri.quality.QualityWarning`) and the normalisation inputs
    used or the fields that were missing."""

    name: str
    a: MriImage
    b: MriImage | None
    specs: dict
    background_specs: tuple
    result: PairResult
    warnings: tuple[QualityWarning, ...]
    normalisation: dict


def methods_for(options: SnrOptions, n_images: int) -> tuple[str, ...]:
    """The methods to run on one image or a pair; pair methods on one image are an error."""
    methods = options.methods or (PAIR_METHODS if n_images == 2 else ("smoothed",))
    if n_images == 1 and set(methods) & set(PAIR_METHODS):
        raise MriError(f"method {sorted(set(methods) & set(PAIR_METHODS))[0]!r} needs two images "
                       f"(a repeated acquisition); one image takes {' or '.join(SINGLE_METHODS)}")
    return tuple(dict.fromkeys(methods))


def _specs(options: SnrOptions, methods, n_slices: int) -> tuple[dict, tuple]:
    def loader(path):
        return load_image(path).pixels

    if options.rois:
        specs = tuple(parse_roi(text, loader) for text in options.rois)
        for spec in specs:
            if spec.mask is not None and spec.mask.shape[0] not in (1, n_slices):
                raise RoiError(f"ROI {spec.text!r}: mask has {spec.mask.shape[0]} slices, the "
                               f"images have {n_slices}")
        by_method = {method: specs for method in methods}
    else:
        by_method = {method: (parse_roi(DEFAULT_ROIS[method]),) for method in methods}
    background = ()
    if "background" in methods:
        background = tuple(parse_roi(t, loader) for t in options.background_rois or (DEFAULT_BACKGROUND_ROI,))
    return by_method, background


def load_pair(path_a, path_b) -> tuple[MriImage, MriImage]:
    """Load two repeated acquisitions and check that they can be compared pixel by pixel
    (:func:`mri.pair.check_pair`: :class:`mri.errors.PairMismatchError` otherwise; harmless
    header differences come back as ``header_differs`` warnings of :func:`measure_pair`)."""
    a, b = load_image(path_a), load_image(path_b)
    check_pair(a, b, (Path(a.source).name, Path(b.source).name))
    return a, b


def measure_pair(a, b=None, options: SnrOptions | None = None, name: str | None = None) -> MeasuredPair:
    """Load (paths) or take (:class:`MriImage`) image ``a`` alone (``b`` None) or the pair,
    check it and measure it by ``options`` (default: thesis and nema for a pair, smoothed for
    one image). The result's ``warnings`` are :class:`mri.quality.QualityWarning` with codes."""
    options = options or SnrOptions()
    a = a if isinstance(a, MriImage) else load_image(a)
    b = b if b is None or isinstance(b, MriImage) else load_image(b)
    name = name or ("pair" if b is not None else "image")
    methods = methods_for(options, 1 if b is None else 2)
    warnings = [] if b is None else [
        QualityWarning("header_differs", text, {})
        for text in check_pair(a, b, (Path(a.source).name, Path(b.source).name))]
    specs, background = _specs(options, methods, a.n_slices)
    inputs, missing = normalisation_inputs(a, options.normalisation)
    factor = None if inputs is None else normalisation_factor(inputs)
    result = measure_arrays(a.pixels, None if b is None else b.pixels, a.pixel_spacing_mm, specs,
                            background, options.kernel_px, factor)
    warnings += result.warnings
    low = [s for s in result.summaries if s.snr < RICIAN_BIAS_SNR]
    if low:
        warnings.append(QualityWarning(
            "rician_bias",
            f"SNR {low[0].snr:.2f} ({low[0].method}) is below {RICIAN_BIAS_SNR:g}: in magnitude "
            "images Rician noise biases it upward (+1 % at 8.7, +24 % at 2)",
            {"method": low[0].method, "snr": low[0].snr, "limit": RICIAN_BIAS_SNR}))
    skipped = [s for s in result.slices if s.skipped]
    if skipped:
        warnings.append(QualityWarning(
            "slices_skipped",
            f"{len(skipped)} of {len(result.slices)} slices skipped (first: slice "
            f"{skipped[0].index}: {skipped[0].skipped})",
            {"skipped": [s.index for s in skipped], "slices": len(result.slices)}))
    if missing and a.format == "dicom":  # other formats carry no such header: no surprise
        warnings.append(QualityWarning(
            "normalisation_missing",
            f"normalised SNR not computed: the header lacks {', '.join(missing)} (give them "
            "with --acquisition FIELD=VALUE)", {"missing": list(missing)}))
    normalisation = ({"factor": factor, "inputs": dataclasses.asdict(inputs)} if inputs
                     else {"factor": None, "missing": list(missing)})
    return MeasuredPair(name, a, b, specs, background, result, tuple(warnings), normalisation)


def figure_panel(title: str, a: MriImage, b: MriImage | None, specs: dict, background: tuple,
                 k: int | None, rois: tuple[Roi, ...] | None = None) -> PairPanel:
    """One figure row: slice ``k`` (default: the middle) of a and b (or a alone) with every
    ROI labelled by the methods using it; ``rois`` replaces them (e.g. refused boxes)."""
    index = a.n_slices // 2 if k is None else k
    if not 0 <= index < a.n_slices:
        raise MriError(f"figure slice {k} is outside 0..{a.n_slices - 1}")
    if rois is None:
        users: dict[str, list[str]] = {}
        for method, method_specs in specs.items():
            for spec in method_specs:
                users.setdefault(spec.text, []).append(method)
        for spec in background:
            users.setdefault(spec.text, []).append("background noise")
        by_text = {spec.text: spec for s in list(specs.values()) + [background] for spec in s}
        rois = tuple(
            Roi(f"{roi.label} ({', '.join(users[text])})", roi.mask)
            for text, spec in by_text.items()
            for roi in resolve_roi(spec, a.pixels[index].astype(float), a.pixel_spacing_mm, index)
        )
    suffix = f", slice {index}" if a.n_slices > 1 else ""
    return PairPanel(f"{title}{suffix}", a.pixels[index], None if b is None else b.pixels[index],
                     rois, Path(a.source).name + suffix, None if b is None else Path(b.source).name,
                     a.pixel_spacing_mm)


def input_sha256(path) -> str:
    """SHA-256 (hex) of an input file, or of a series folder: its files' relative names and
    contents in sorted order."""
    import hashlib

    p, digest = Path(path), hashlib.sha256()
    files = sorted(f for f in p.rglob("*") if f.is_file()) if p.is_dir() else [p]
    for f in files:
        if p.is_dir():
            digest.update(str(f.relative_to(p)).encode() + b"\0")
        digest.update(f.read_bytes())
    return digest.hexdigest()


def _meta(img: MriImage) -> dict:
    return {
        "source": img.source, "sha256": input_sha256(img.source), "format": img.format,
        "shape": list(img.shape),
        "pixel_spacing_mm": img.pixel_spacing_mm, "slice_thickness_mm": img.slice_thickness_mm,
        "orientation": img.orientation, "scanner": img.scanner, "series": img.series,
        "series_number": img.series_number, "acquisition": img.acquisition,
    }


def pair_dict(pair: MeasuredPair) -> dict:
    """The JSON of one measured image or pair."""
    return {
        "a": _meta(pair.a),
        "b": None if pair.b is None else _meta(pair.b),
        "rois": {m: [s.text for s in specs] for m, specs in pair.specs.items()},
        "background_rois": [s.text for s in pair.background_specs],
        "normalisation": pair.normalisation,
        **dataclasses.asdict(pair.result),
        "warnings": [dataclasses.asdict(w) for w in pair.warnings],
    }


CSV_HEADER = ("pair", "slice", "method", "image", "roi", "n_pixels", "signal", "noise", "snr",
              "difference_percent")


def csv_rows(pairs: list[MeasuredPair]):
    """Per-slice, per-method, per-image, per-ROI rows under :data:`CSV_HEADER`."""
    for pair in pairs:
        for s in pair.result.slices:
            for m in s.methods:
                for r in m.rois:
                    yield (pair.name, s.index, m.method, m.image, r.roi, r.n_pixels, r.signal,
                           r.noise, r.snr, s.difference_percent)


def write_csv(path, pairs: list[MeasuredPair]) -> None:
    """The rows of :func:`csv_rows` under :data:`CSV_HEADER`, written atomically."""
    import csv

    from geometry.atomic import atomic_path

    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(CSV_HEADER)
        writer.writerows(csv_rows(pairs))


# --------------------------------------------------------------------------- text


def describe(img) -> str:
    """One line on an image: format, size, spacing, scanner, series."""
    s, r, c = img.shape
    parts = [img.format.upper(), f"{r} x {c}" + (f" x {s} slices" if s > 1 else "")]
    if img.pixel_spacing_mm:
        parts.append("pixel {:.3f} x {:.3f} mm".format(*img.pixel_spacing_mm))
    if img.slice_thickness_mm:
        parts.append(f"slice {img.slice_thickness_mm:g} mm")
    if img.scanner:
        field = img.acquisition.get("field_strength_t")
        parts.append(img.scanner + (f" {field:g} T" if isinstance(field, float) else ""))
    if img.series:
        parts.append(f"series {img.series_number or ''} {img.series!r}".replace("  ", " "))
    return f"{img.source} ({', '.join(parts)})"


def pair_text(pair) -> list[str]:
    """The text report of one measured image or pair."""
    res = pair.result
    lines = [f"a: {describe(pair.a)}"] + ([f"b: {describe(pair.b)}"] if pair.b else [])
    if len(res.slices) == 1:
        lines.append(f"{'method':<10} {'image':<5} {'ROI':<36} {'pixels':>7} {'signal':>10} "
                     f"{'noise':>9} {'SNR':>9}")
        for m in res.slices[0].methods:
            for r in m.rois:
                lines.append(f"{m.method:<10} {m.image:<5} {r.roi:<36} {r.n_pixels:>7} "
                             f"{r.signal:>10.2f} {r.noise:>9.3f} {r.snr:>9.2f}")
            if len(m.rois) > 1:
                lines.append(f"{m.method:<10} {m.image:<5} {'mean of ' + str(len(m.rois)) + ' ROIs':<36} "
                             f"{'':>7} {m.signal:>10.2f} {m.noise:>9.3f} {m.snr:>9.2f}")
            if m.noise_rois:
                lines.append(f"{'':<10} {'':<5} noise from {', '.join(m.noise_rois)}")
    else:
        lines.append(f"{'slice':>5} {'method':<10} {'image':<5} {'signal':>10} {'noise':>9} "
                     f"{'SNR':>9} {'diff %':>8}")
        for s in res.slices:
            if s.skipped:
                lines.append(f"{s.index:>5} skipped: {s.skipped}")
            diff = "" if s.difference_percent is None else f"{s.difference_percent:>8.3f}"
            for m in s.methods:
                lines.append(f"{s.index:>5} {m.method:<10} {m.image:<5} {m.signal:>10.2f} "
                             f"{m.noise:>9.3f} {m.snr:>9.2f} {diff}")
        measured = sum(1 for s in res.slices if not s.skipped)
        for summary in res.summaries:
            lines.append(
                f"{summary.method} over {measured} of {len(res.slices)} slices: SNR mean "
                f"{summary.snr:.2f} (min {summary.snr_min:.2f}, max {summary.snr_max:.2f}), "
                f"signal {summary.signal:.2f}, noise {summary.noise:.3f}"
            )
    lines.append("SNR with its 95 % interval (sampling error of the noise estimate): " + "; ".join(
        f"{s.method} {s.snr:.2f} [{s.snr_ci95[0]:.2f}, {s.snr_ci95[1]:.2f}]" for s in res.summaries))
    if res.normalisation_factor is None:
        lines.append("normalised SNR: not computed, the header lacks "
                     f"{', '.join(pair.normalisation['missing'])} (give them with --acquisition)")
    else:
        lines.append(f"normalised SNR (factor {res.normalisation_factor:.4f}): " + ", ".join(
            f"{s.method} {s.snr_normalised:.1f}" for s in res.summaries))
    if res.difference_percent is not None:
        lines.append(f"difference sum|a-b| / sum a: {res.difference_percent:.3f} %")
    return lines


def _change(new: float, old: float) -> float:
    return 100.0 * (new - old) / old


def comparison_json(reference, conditions) -> dict:
    """The JSON of conditions against the reference; ``conditions``: (pair, warnings vs the
    reference, difference vs the reference in percent)."""
    return {
        "reference": pair_dict(reference),
        "conditions": [
            {
                "name": pair.name,
                "snr_change_percent": {
                    s.method: _change(s.snr, reference.result.summary(s.method).snr)
                    for s in pair.result.summaries
                },
                "difference_vs_reference_percent": diff,
                "warnings_vs_reference": list(warnings),
                **pair_dict(pair),
            }
            for pair, warnings, diff in conditions
        ],
    }


def comparison_text(reference, conditions) -> list[str]:
    """The text table of conditions against the reference: SNR, change, difference."""
    lines = [f"reference: {reference.a.source}, {reference.b.source}"]
    lines += [f"{pair.name}: {pair.a.source}, {pair.b.source}" for pair, _, _ in conditions]
    lines.append(f"{'condition':<16} {'method':<10} {'SNR':>9} {'change':>9} {'difference vs reference':>24}")
    for s in reference.result.summaries:
        lines.append(f"{'reference':<16} {s.method:<10} {s.snr:>9.2f} {'':>9} {'':>24}")
    for pair, _, diff in conditions:
        for s in pair.result.summaries:
            change = _change(s.snr, reference.result.summary(s.method).snr)
            lines.append(f"{pair.name:<16} {s.method:<10} {s.snr:>9.2f} {change:>+8.1f}% {diff:>23.3f}%")
    return lines
