"""``dacm draw``: a picture of a design's profile (:mod:`geometry.drawing`), PNG or SVG."""

from __future__ import annotations

import argparse

from geometry.atomic import save_figure
from geometry.checks import assert_feasible
from sensor.cli.design_args import add_design_arguments, check_flags, design_from_args
from sensor.cli.output import add_output_arguments, claim, staged
from sensor.errors import UsageError
from sensor.validation import Number

IMAGE_FORMATS = ("png", "svg")
#: Rule of --dpi: a 6-inch figure at 1200 dpi is 7200 px wide.
DPI_RULE = Number(10.0, 1200.0, unit="dots per inch")


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "draw", help="picture of a design's profile (PNG/SVG)",
        description="Draw the profile of one design like thesis Figure 48: hinge numbers, "
                    "input and output ports, phi1/phi2 and the footprint w x h. Writes "
                    "OUT/<name>-profile.png (or .svg with --format svg).")
    add_design_arguments(p)
    add_output_arguments(p, "the picture <name>-profile.png|svg")
    p.add_argument("--format", default="png", metavar="FMT",
                   help=f"{' | '.join(IMAGE_FORMATS)} (default png)")
    p.add_argument("--dpi", type=float, default=200.0, help="resolution of a PNG (default 200)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from geometry.drawing import profile_figure

    if args.format not in IMAGE_FORMATS:
        raise UsageError(f"--format = {args.format!r}: must be one of {', '.join(IMAGE_FORMATS)}")
    check_flags(args, {"dpi": DPI_RULE})
    design = design_from_args(args)
    [path] = claim(args, [f"{design.name}-profile.{args.format}"])
    assert_feasible(design)
    fig = profile_figure(design)
    with staged(args) as stage:
        save_figure(fig, stage / path.name, dpi=args.dpi)
    print(f"wrote {path}")
    return 0
