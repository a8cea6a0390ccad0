"""``dacm snr``: SNR (thesis eqs 91-93, NEMA MS 1, McCann et al. 2013) and image difference.

Modes: ``dacm snr A B`` (a repeated-acquisition pair), ``dacm snr A`` (one image, single-image
methods) and ``dacm snr --reference A1 A2 --condition NAME B1 B2 ...`` (each condition against
a reference pair, as the thesis compared the sensor in zones I and II with no sensor).
Measuring, checks and JSON shapes live in :mod:`mri.study`; this module parses and prints.
"""

from __future__ import annotations

import sys
from pathlib import Path

from sensor.cli.output import print_json
from sensor.errors import UsageError

#: = mri.snr.METHODS (not imported here: ``dacm --help`` must not import numpy/scipy).
METHOD_CHOICES = ("thesis", "nema", "smoothed", "background")
FIGURE_SUFFIXES = (".png", ".svg", ".pdf")

_ROI_HELP = (
    "signal region of interest, repeatable (used by every method): whole | "
    "box:ROW:COL:HEIGHT:WIDTH (pixels, top-left corner, zero-based) | central-box:SIZE[:WIDTH] | "
    "central-circle:DIAMETER | mask:PATH | phantom[:EROSION] | nema5[:SIZE[:OFFSET]] | "
    "corners[:SIZE]; sizes in pixels or with an mm suffix (e.g. central-circle:80mm). "
    "Default: whole image for thesis, nema5 for the others"
)


def register(subparsers) -> None:
    parser = subparsers.add_parser(
        "snr",
        help="SNR and difference of MR images (thesis Appendix C, NEMA MS 1, McCann 2013)",
        description=(
            "Measure SNR from two repeated acquisitions (DICOM file or series folder, NIfTI, "
            "PNG/TIFF, NPY) by the thesis method (eqs 91-93) and the NEMA MS 1 subtraction "
            "method, or from one image by the smoothed-subtraction (McCann et al. 2013) or "
            "NEMA background method, and the thesis' difference sum|a-b|/sum a."
        ),
    )
    parser.add_argument("images", nargs="*", metavar="IMAGE", help="the pair A B, or one image A")
    parser.add_argument(
        "--method", choices=METHOD_CHOICES, action="append",
        help="measure this method (repeatable; default: thesis and nema for a pair, smoothed "
             "for one image); smoothed and background measure each image of a pair",
    )
    parser.add_argument("--roi", action="append", default=[], metavar="ROI", help=_ROI_HELP)
    parser.add_argument("--background-roi", action="append", default=[], metavar="ROI",
                        help="air ROI of the background method, repeatable (default: corners)")
    parser.add_argument("--kernel", type=int, default=9, metavar="PX",
                        help="boxcar of the smoothed method (9 head coil, 25 body coil)")
    parser.add_argument("--acquisition", action="append", default=[], metavar="FIELD=VALUE",
                        help="override a header value of the normalised SNR, repeatable: "
                             "pixel_row_mm, pixel_col_mm, slice_thickness_mm, pixel_bandwidth_hz, "
                             "readout_samples, phase_steps, averages, repetition_time_ms")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--csv", metavar="PATH", help="write per-slice, per-ROI results as CSV")
    parser.add_argument("--force", action="store_true",
                        help="replace the --csv/--figure/--report files if they exist")
    parser.add_argument("--figure", metavar="PNG",
                        help="write a, b and a - b side by side with the ROIs drawn")
    parser.add_argument("--figure-slice", type=int, metavar="K",
                        help="slice of a volume to draw (default: middle)")
    parser.add_argument("--report", metavar="HTML",
                        help="write one self-contained HTML report (figure, tables, checks)")
    parser.add_argument("--reference", nargs=2, metavar=("A1", "A2"),
                        help="reference pair (e.g. no sensor)")
    parser.add_argument("--condition", nargs=3, action="append", default=[],
                        metavar=("NAME", "B1", "B2"),
                        help="a condition's pair, compared with the reference (repeatable)")
    parser.set_defaults(func=run)


def _options(args):
    from mri.study import SnrOptions

    overrides = {}
    for item in args.acquisition:
        key, sep, value = item.partition("=")
        try:
            overrides[key.strip()] = float(value)
        except ValueError:
            sep = ""
        if not sep:
            raise UsageError(f"--acquisition {item!r}: expected FIELD=NUMBER, e.g. averages=2")
    return SnrOptions(tuple(args.method) if args.method else None, tuple(args.roi),
                      tuple(args.background_roi), args.kernel, overrides)


def _check_mode(args) -> None:
    if args.reference:
        if args.images:
            raise UsageError("give either images A [B] or --reference A1 A2, not both")
        if not args.condition:
            raise UsageError("--reference needs at least one --condition NAME B1 B2")
    else:
        if args.condition:
            raise UsageError("--condition needs --reference A1 A2")
        if len(args.images) not in (1, 2):
            raise UsageError(f"expected one image A or a pair A B (a repeated acquisition), "
                             f"got {len(args.images)}")
    if args.figure and Path(args.figure).suffix.lower() not in FIGURE_SUFFIXES:
        raise UsageError(f"--figure {args.figure}: the file name must end in "
                         f"{', '.join(FIGURE_SUFFIXES)}")
    if args.report and Path(args.report).suffix.lower() not in (".html", ".htm"):
        raise UsageError(f"--report {args.report}: the file name must end in .html")


def _measure(name, path_a, path_b, args, options):
    """Measure; boxes refused on a single slice are drawn in --figure before the error."""
    from mri.errors import BoxOutsidePhantomError
    from mri.study import figure_panel, measure_pair

    try:
        return measure_pair(path_a, path_b, options, name)
    except BoxOutsidePhantomError as exc:
        if not args.figure:
            raise
        from mri.io import load_image

        a, b = load_image(path_a), None if path_b is None else load_image(path_b)
        from sensor.report.snr_report import write_snr_outputs

        write_snr_outputs(None, args.figure, None, [], [figure_panel(name, a, b, {}, (), 0, exc.rois)])
        raise type(exc)(f"{exc}; the boxes are drawn in {args.figure}") from None


def _write_outputs(args, pairs, panels, comparison=None) -> None:
    """The --csv, --figure and --report files as one set (sensor.report.snr_report.write_snr_outputs)."""
    from sensor.report.snr_report import write_snr_outputs

    command = "dacm snr " + " ".join(sys.argv[2:]) if sys.argv[1:2] == ["snr"] else "dacm snr"
    write_snr_outputs(args.csv, args.figure, args.report, pairs, panels, comparison, command)


def _written(args) -> list[str]:
    """The files a run wrote: those given to --csv, --figure and --report."""
    return [p for p in (args.csv, args.figure, args.report) if p]


def run(args) -> int:
    from sensor.cli.output import claim_files

    _check_mode(args)
    claim_files({"--csv": args.csv, "--figure": args.figure, "--report": args.report}, args.force)
    options = _options(args)
    if args.reference:
        return _run_conditions(args, options)
    from mri.study import figure_panel, pair_dict

    path_b = args.images[1] if len(args.images) == 2 else None
    pair = _measure("pair" if path_b else "image", args.images[0], path_b, args, options)
    panels = [figure_panel(pair.name, pair.a, pair.b, pair.specs, pair.background_specs,
                           args.figure_slice)] if args.figure or args.report else []
    _write_outputs(args, [pair], panels)
    if args.json:
        print_json(pair_dict(pair), _written(args))
    else:
        from mri.study import pair_text

        print("\n".join(pair_text(pair)))
        for warning in pair.warnings:  # text mode, after the outputs (an error stays alone)
            print(f"dacm snr: warning: {warning}", file=sys.stderr)
    return 0


def _run_conditions(args, options) -> int:
    from mri.pair import check_pair
    from mri.snr import difference_percent
    from mri.study import comparison_json, comparison_text, figure_panel

    reference = _measure("reference", *args.reference, args, options)
    names = [name for name, _, _ in args.condition]
    if len(set(names + ["reference"])) != len(names) + 1:
        raise UsageError(f"condition names must be unique and not 'reference': {names}")
    conditions = []
    for name, b1, b2 in args.condition:
        pair = _measure(name, b1, b2, args, options)
        warnings = check_pair(reference.a, pair.a, ("reference", name))
        conditions.append((pair, warnings, difference_percent(reference.a.pixels, pair.a.pixels)))
    panels = [figure_panel(f"reference vs {p.name}", reference.a, p.a, p.specs, p.background_specs,
                           args.figure_slice) for p, _, _ in conditions] if args.figure or args.report else []
    _write_outputs(args, [reference] + [c[0] for c in conditions], panels, (reference, conditions))
    if args.json:
        print_json(comparison_json(reference, conditions), _written(args))
    else:
        print("\n".join(comparison_text(reference, conditions)))
        for pair in [reference] + [c[0] for c in conditions]:  # text mode, after the outputs
            for warning in pair.warnings:
                print(f"dacm snr: warning: {pair.name}: {warning}", file=sys.stderr)
        for pair, warnings, _ in conditions:
            for warning in warnings:
                print(f"dacm snr: warning: reference vs {pair.name}: {warning}", file=sys.stderr)
    return 0
