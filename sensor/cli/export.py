"""``dacm export``: write a design's DXF (water-jet), STL, STEP and JSON beam model."""

from __future__ import annotations

import argparse
from pathlib import Path

from geometry.params import FIELD_RULES
from sensor.cli.design_args import add_design_arguments, check_flags, design_from_args


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "export", help="write DXF / STL / STEP / JSON beam model of a design",
        description="Write the files of one design as OUT/<name>.<ext>: DXF for water-jet "
                    "cutting (mm, one closed polyline per outline, layers OUTLINE and HOLES), "
                    "STL and STEP of the extruded body, and the JSON beam model. Without a "
                    "format flag all four are written. The design is checked for feasibility "
                    "first; nothing is written if any check fails.")
    add_design_arguments(p)
    p.add_argument("--out", type=Path, default=Path("."), metavar="DIR",
                   help="output folder, created if missing (default: the current folder)")
    for fmt, what in (("dxf", "2D profile for the water-jet"), ("stl", "3D mesh"),
                      ("step", "3D solid"), ("json", "beam model for the solver")):
        p.add_argument(f"--{fmt}", action="store_true", help=f"write the {what}")
    p.add_argument("--kerf", type=float, metavar="MM",
                   help="cutting kerf: the DXF holds the jet's centre path, the outline moved "
                        "out and the holes in by MM/2 (also used as the design's kerf_mm in "
                        "the gap check)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from geometry.export import FORMATS, export_design  # CadQuery: load only when used

    check_flags(args, {"kerf": FIELD_RULES["kerf_mm"]})
    design = design_from_args(args)
    if args.kerf is not None:
        design = design.replace(kerf_mm=args.kerf)
    formats = [f for f in FORMATS if getattr(args, f)] or list(FORMATS)
    for path in export_design(design, args.out, formats, kerf_mm=args.kerf):
        print(f"wrote {path}")
    return 0
