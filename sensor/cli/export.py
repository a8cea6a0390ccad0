"""``dacm export``: write a design's DXF (water-jet), STL, STEP and JSON beam model."""

from __future__ import annotations

import argparse

from geometry.params import FIELD_RULES
from sensor.cli.design_args import add_design_arguments, check_flags, design_from_args
from sensor.cli.output import add_output_arguments, claim, print_json, staged
from sensor.cli.progress import add_quiet_argument, busy

#: Format flags: flag -> (format of geometry.export, what it is).
FORMAT_FLAGS = {"dxf": ("dxf", "2D profile for the water-jet"), "stl": ("stl", "3D mesh"),
                "step": ("step", "3D solid"),
                "beam_model": ("json", "beam model for the solver, <name>.json (dacm solve --model)")}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "export", help="write DXF / STL / STEP / JSON beam model of a design",
        description="Write the files of one design as OUT/<name>.<ext>: DXF for water-jet "
                    "cutting (mm, one closed polyline per outline, layers OUTLINE and HOLES), "
                    "STL and STEP of the extruded body, and the JSON beam model. Without a "
                    "format flag all four are written. The design is checked for feasibility "
                    "first; nothing is written if any check fails.")
    add_design_arguments(p)
    add_output_arguments(p, "the files")
    for flag, (_, what) in FORMAT_FLAGS.items():
        p.add_argument(f"--{flag.replace('_', '-')}", action="store_true", help=f"write the {what}")
    p.add_argument("--kerf", type=float, metavar="MM",
                   help="cutting kerf: the DXF holds the jet's centre path, the outline moved "
                        "out and the holes in by MM/2 (also used as the design's kerf_mm in "
                        "the gap check)")
    p.add_argument("--json", action="store_true", help="print the files written as JSON")
    add_quiet_argument(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    check_flags(args, {"kerf": FIELD_RULES["kerf_mm"]})
    design = design_from_args(args)
    if args.kerf is not None:
        design = design.replace(kerf_mm=args.kerf)
    formats = [fmt for flag, (fmt, _) in FORMAT_FLAGS.items() if getattr(args, flag)]
    formats = formats or [fmt for fmt, _ in FORMAT_FLAGS.values()]
    written = claim(args, [f"{design.name}.{fmt}" for fmt in formats])
    with busy(f"export {design.name}: {', '.join(formats)}", args.quiet):
        from geometry.export import export_design  # CadQuery: load only when used

        with staged(args) as stage:
            export_design(design, stage, formats, kerf_mm=args.kerf)
    if args.json:
        print_json({"design": design.name, "kerf_mm": args.kerf, "formats": formats}, written)
        return 0
    for path in written:
        print(f"wrote {path}")
    return 0
