"""``dacm report``: one self-contained HTML page of a design (profile, solve, datasheet,
render, continuum verification, export files with checksums, inputs and versions)."""

from __future__ import annotations

import argparse

from geometry import provenance
from sensor.cli.design_args import add_design_arguments, check_flags, design_from_args, travel_rule
from sensor.cli.output import add_output_arguments, claim, print_json, staged
from sensor.cli.progress import add_quiet_argument, busy


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "report", help="one self-contained HTML report of a design, with the files to make it",
        description="Solve a design, build its sensor datasheet, render it, verify it against "
                    "the continuum model (when this version has one) and export its files, "
                    "then write OUT/<name>-report.html: one page with every figure embedded "
                    "(it opens offline and loads nothing) beside OUT/<name>.dxf, .stl, .step, "
                    ".json and .toml, listed in it with their sizes and SHA-256.")
    add_design_arguments(p)
    p.add_argument("--target-output", type=float, default=1.0, metavar="MM",
                   help="output (mirror) travel to solve to and full scale of the datasheet, "
                        "mm (default 1)")
    p.add_argument("--no-verify", action="store_true",
                   help="skip the continuum verification (it takes about 20 s)")
    add_output_arguments(p, "the report and its files")
    p.add_argument("--json", action="store_true",
                   help="print the report's numbers and files as JSON")
    add_quiet_argument(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from sensor.report.design_report import output_paths, write_design_report

    design = design_from_args(args)
    check_flags(args, {"target_output": travel_rule(design.height_mm)})
    claim(args, [p.name for p in output_paths(design, args.out)])
    command = provenance.command()
    with busy(f"report {design.name}" + ("" if args.no_verify else " (with the continuum "
                                         "verification, about 20 s)"), args.quiet):
        with staged(args) as stage:
            report = write_design_report(design, stage, target_output_mm=args.target_output,
                                         verify=not args.no_verify, command=command, force=True)
    path = args.out / report.path.name
    report.summary["report"] = str(path)
    if args.json:
        print_json({k: v for k, v in report.summary.items() if k != "files"},
                   [args.out / f.name for f in report.files] + [path])
        return 0
    s, v = report.summary["solve"], report.summary["verification"]
    print(f"{design.name}: A = {s['amplification']:.4f}, range {s['range_N']:.4f} N, "
          f"H = {100 * s['hysteresis']:.3f} % FS; verification: {v['status']}"
          + (f": {v['reason']}" if v["status"] != "run" else ""))
    for f in report.files:
        print(f"wrote {args.out / f.name}")
    print(f"wrote {path}")
    return 0
