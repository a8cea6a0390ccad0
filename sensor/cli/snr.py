"""``dacm snr``: SNR (thesis eqs 91-93 and NEMA MS 1) and image difference of MR image pairs.

Two modes:

* ``dacm snr A B``: one repeated-acquisition pair;
* ``dacm snr --reference A1 A2 --condition NAME B1 B2 ...``: each condition's pair against a
  reference pair, as the thesis compared the sensor in zones I and II with no sensor.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import sys
from pathlib import Path

from geometry.atomic import atomic_path, save_figure
from mri.errors import RoiError
from mri.figure import PairPanel, pair_figure
from mri.image import MriImage
from mri.io import load_image
from mri.pair import check_pair
from mri.roi import Roi, parse_roi, resolve_roi
from mri.snr import (
    DEFAULT_ROIS,
    METHODS,
    RICIAN_BIAS_SNR,
    PairResult,
    difference_percent,
    measure_pair,
)
from sensor.errors import UsageError

_ROI_HELP = (
    "region of interest, repeatable (used by every method): whole | box:ROW:COL:HEIGHT:WIDTH "
    "(pixels, top-left corner, zero-based) | central-box:SIZE[:WIDTH] | central-circle:DIAMETER "
    "| mask:PATH | phantom[:EROSION] | nema5[:SIZE[:OFFSET]]; sizes in pixels or with an mm "
    "suffix (e.g. central-circle:80mm). Default: whole image for thesis, nema5 for nema"
)


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "snr",
        help="SNR and difference of MR image pairs (thesis Appendix C, NEMA MS 1)",
        description=(
            "Measure SNR from two repeated acquisitions (DICOM file or series folder, NIfTI, "
            "PNG/TIFF, NPY) by the thesis method (eqs 91-93) and the NEMA MS 1 subtraction "
            "method, and the thesis' difference sum|a-b|/sum a."
        ),
    )
    parser.add_argument("images", nargs="*", metavar="IMAGE", help="the pair A B")
    parser.add_argument(
        "--method", choices=METHODS, help="measure only this method (default: both)"
    )
    parser.add_argument("--roi", action="append", default=[], metavar="ROI", help=_ROI_HELP)
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--csv", metavar="PATH", help="write per-slice, per-ROI results as CSV")
    parser.add_argument(
        "--figure", metavar="PNG", help="write a, b and a - b side by side with the ROIs drawn"
    )
    parser.add_argument(
        "--figure-slice", type=int, metavar="K", help="slice of a volume to draw (default: middle)"
    )
    parser.add_argument(
        "--reference", nargs=2, metavar=("A1", "A2"), help="reference pair (e.g. no sensor)"
    )
    parser.add_argument(
        "--condition",
        nargs=3,
        action="append",
        default=[],
        metavar=("NAME", "B1", "B2"),
        help="a condition's pair, compared with the reference (repeatable)",
    )
    parser.set_defaults(func=run)


# --------------------------------------------------------------------------- measuring


@dataclasses.dataclass(frozen=True, eq=False)
class MeasuredPair:
    """A loaded, checked and measured pair with its name, ROI specs and warnings."""

    name: str
    a: MriImage
    b: MriImage
    specs: dict
    result: PairResult
    warnings: tuple[str, ...]


def _specs(roi_texts: list[str], methods: tuple[str, ...], n_slices: int) -> dict:
    """ROI specs per method: the user's ROIs for every method, or each method's default."""
    def loader(path):
        return load_image(path).pixels

    if roi_texts:
        specs = tuple(parse_roi(text, loader) for text in roi_texts)
        for spec in specs:
            if spec.mask is not None and spec.mask.shape[0] not in (1, n_slices):
                raise RoiError(
                    f"ROI {spec.text!r}: mask has {spec.mask.shape[0]} slices, the images have "
                    f"{n_slices}"
                )
        return {method: specs for method in methods}
    return {method: (parse_roi(DEFAULT_ROIS[method]),) for method in methods}


def _measure(name: str, path_a: str, path_b: str, args, methods) -> MeasuredPair:
    a, b = load_image(path_a), load_image(path_b)
    warnings = check_pair(a, b, (Path(path_a).name, Path(path_b).name))
    specs = _specs(args.roi, methods, a.n_slices)
    result = measure_pair(a.pixels, b.pixels, a.pixel_spacing_mm, specs)
    low = [s for s in result.summaries if s.snr < RICIAN_BIAS_SNR]
    if low:
        warnings += (
            f"SNR {low[0].snr:.2f} ({low[0].method}) is below {RICIAN_BIAS_SNR:g}: in magnitude "
            "images Rician noise biases it upward (+1 % at 8.7, +24 % at 2)",
        )
    return MeasuredPair(name, a, b, specs, result, warnings)


def _figure_panels(pairs: list[tuple[str, MriImage, MriImage, dict]], k: int | None) -> list[PairPanel]:
    panels = []
    for title, a, b, specs in pairs:
        index = a.n_slices // 2 if k is None else k
        if not 0 <= index < a.n_slices:
            raise UsageError(f"--figure-slice {k} is outside 0..{a.n_slices - 1}")
        users: dict[str, list[str]] = {}
        for method, method_specs in specs.items():
            for spec in method_specs:
                users.setdefault(spec.text, []).append(method)
        by_text = {spec.text: spec for method_specs in specs.values() for spec in method_specs}
        rois = tuple(
            Roi(f"{roi.label} ({', '.join(users[text])})", roi.mask)
            for text, spec in by_text.items()
            for roi in resolve_roi(spec, a.pixels[index], a.pixel_spacing_mm, index)
        )
        suffix = f", slice {index}" if a.n_slices > 1 else ""
        panels.append(
            PairPanel(f"{title}{suffix}", a.pixels[index], b.pixels[index], rois,
                      difference_percent(a.pixels[index], b.pixels[index]),
                      Path(a.source).name, Path(b.source).name)
        )
    return panels


def _write_figure(path: str, panels: list[PairPanel]) -> None:
    fig = pair_figure(panels)
    save_figure(fig, path)


def _write_csv(path: str, pairs: list[MeasuredPair]) -> None:
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(["pair", "slice", "method", "roi", "n_pixels", "signal", "noise", "snr",
                         "difference_percent"])
        for pair in pairs:
            for s in pair.result.slices:
                for m in s.methods:
                    for r in m.rois:
                        writer.writerow([pair.name, s.index, m.method, r.roi, r.n_pixels,
                                         r.signal, r.noise, r.snr, s.difference_percent])


# --------------------------------------------------------------------------- reporting


def _meta(img: MriImage) -> dict:
    return {
        "source": img.source,
        "format": img.format,
        "shape": list(img.shape),
        "pixel_spacing_mm": img.pixel_spacing_mm,
        "slice_thickness_mm": img.slice_thickness_mm,
        "orientation": img.orientation,
        "scanner": img.scanner,
        "series": img.series,
        "series_number": img.series_number,
        "acquisition": img.acquisition,
    }


def _pair_dict(pair: MeasuredPair) -> dict:
    return {
        "a": _meta(pair.a),
        "b": _meta(pair.b),
        "rois": {m: [s.text for s in specs] for m, specs in pair.specs.items()},
        "warnings": list(pair.warnings),
        **dataclasses.asdict(pair.result),
    }


def _describe(img: MriImage) -> str:
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


def _pair_text(pair: MeasuredPair) -> list[str]:
    res = pair.result
    lines = [f"a: {_describe(pair.a)}", f"b: {_describe(pair.b)}"]
    if len(res.slices) == 1:
        lines.append(f"{'method':<7} {'ROI':<36} {'pixels':>7} {'signal':>10} {'noise':>9} {'SNR':>9}")
        for m in res.slices[0].methods:
            for r in m.rois:
                lines.append(f"{m.method:<7} {r.roi:<36} {r.n_pixels:>7} {r.signal:>10.2f} "
                             f"{r.noise:>9.3f} {r.snr:>9.2f}")
            if len(m.rois) > 1:
                lines.append(f"{m.method:<7} {'mean of ' + str(len(m.rois)) + ' ROIs':<36} {'':>7} "
                             f"{m.signal:>10.2f} {m.noise:>9.3f} {m.snr:>9.2f}")
    else:
        lines.append(f"{'slice':>5} {'method':<7} {'signal':>10} {'noise':>9} {'SNR':>9} {'diff %':>8}")
        for s in res.slices:
            if s.skipped:
                lines.append(f"{s.index:>5} skipped: {s.skipped}")
            for m in s.methods:
                lines.append(f"{s.index:>5} {m.method:<7} {m.signal:>10.2f} {m.noise:>9.3f} "
                             f"{m.snr:>9.2f} {s.difference_percent:>8.3f}")
        for summary in res.summaries:
            measured = sum(1 for s in res.slices if not s.skipped)
            lines.append(
                f"{summary.method} over {measured} of {len(res.slices)} slices: SNR mean {summary.snr:.2f} "
                f"(min {summary.snr_min:.2f}, max {summary.snr_max:.2f}), signal {summary.signal:.2f}, "
                f"noise {summary.noise:.3f}"
            )
    lines.append(f"difference sum|a-b| / sum a: {res.difference_percent:.3f} %")
    return lines


def _change(new: float, old: float) -> float:
    return 100.0 * (new - old) / old


# --------------------------------------------------------------------------- entry point


def _check_mode(args) -> None:
    if args.reference:
        if args.images:
            raise UsageError("give either a pair A B or --reference A1 A2, not both")
        if not args.condition:
            raise UsageError("--reference needs at least one --condition NAME B1 B2")
    else:
        if args.condition:
            raise UsageError("--condition needs --reference A1 A2")
        if len(args.images) != 2:
            raise UsageError(
                f"expected two images A B (a repeated acquisition), got {len(args.images)}"
            )


def run(args) -> int:
    _check_mode(args)
    methods = (args.method,) if args.method else METHODS
    if args.reference:
        return _run_conditions(args, methods)
    pair = _measure("pair", args.images[0], args.images[1], args, methods)
    for warning in pair.warnings:
        print(f"dacm snr: warning: {warning}", file=sys.stderr)
    if args.csv:
        _write_csv(args.csv, [pair])
    if args.figure:
        _write_figure(args.figure, _figure_panels([("pair", pair.a, pair.b, pair.specs)], args.figure_slice))
    if args.json:
        print(json.dumps(_pair_dict(pair), indent=2))
    else:
        print("\n".join(_pair_text(pair)))
    return 0


def _run_conditions(args, methods) -> int:
    reference = _measure("reference", *args.reference, args, methods)
    names = [name for name, _, _ in args.condition]
    if len(set(names + ["reference"])) != len(names) + 1:
        raise UsageError(f"condition names must be unique and not 'reference': {names}")
    conditions = []
    for name, b1, b2 in args.condition:
        pair = _measure(name, b1, b2, args, methods)
        warnings = check_pair(reference.a, pair.a, ("reference", name))
        conditions.append((pair, warnings, difference_percent(reference.a.pixels, pair.a.pixels)))
    for pair in [reference] + [c[0] for c in conditions]:
        for warning in pair.warnings:
            print(f"dacm snr: warning: {pair.name}: {warning}", file=sys.stderr)
    for pair, warnings, _ in conditions:
        for warning in warnings:
            print(f"dacm snr: warning: reference vs {pair.name}: {warning}", file=sys.stderr)
    if args.csv:
        _write_csv(args.csv, [reference] + [c[0] for c in conditions])
    if args.figure:
        _write_figure(
            args.figure,
            _figure_panels(
                [(f"reference vs {p.name}", reference.a, p.a, p.specs) for p, _, _ in conditions],
                args.figure_slice,
            ),
        )
    if args.json:
        print(json.dumps({
            "reference": _pair_dict(reference),
            "conditions": [
                {
                    "name": pair.name,
                    "snr_change_percent": {
                        s.method: _change(s.snr, reference.result.summary(s.method).snr)
                        for s in pair.result.summaries
                    },
                    "difference_vs_reference_percent": diff,
                    "warnings_vs_reference": list(warnings),
                    **_pair_dict(pair),
                }
                for pair, warnings, diff in conditions
            ],
        }, indent=2))
        return 0
    lines = [f"reference: {', '.join(args.reference)}"]
    lines += [f"{name}: {b1}, {b2}" for name, b1, b2 in args.condition]
    lines.append(f"{'condition':<16} {'method':<7} {'SNR':>9} {'change':>9} {'difference vs reference':>24}")
    for s in reference.result.summaries:
        lines.append(f"{'reference':<16} {s.method:<7} {s.snr:>9.2f} {'':>9} {'':>24}")
    for pair, _, diff in conditions:
        for s in pair.result.summaries:
            change = _change(s.snr, reference.result.summary(s.method).snr)
            lines.append(f"{pair.name:<16} {s.method:<7} {s.snr:>9.2f} {change:>+8.1f}% {diff:>23.3f}%")
    print("\n".join(lines))
    return 0
