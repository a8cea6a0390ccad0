"""``dacm check``: the feasibility report of a design and its kinematic amplification."""

from __future__ import annotations

import argparse
import dataclasses

from sensor.cli.design_args import add_design_arguments, design_from_args
from sensor.cli.output import print_json


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "check", help="feasibility report of a design (every rule, pass or fail)",
        description="Evaluate every feasibility rule of a design (angle limits, minimum "
                    "feature, hinge fit, each hinge's width on its face, footprint, crossing "
                    "parts, kerf gaps, platform) and "
                    "print the kinematic amplification A_kin = 1/2 + cot(phi2) / (2 tan(phi1)). "
                    "Exit status 0 if feasible, 1 if a rule fails, 2 for bad input.")
    add_design_arguments(p)
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from geometry.checks import check_design
    from geometry.layout import kinematic_amplification

    d = design_from_args(args)
    report = check_design(d)
    a_kin = kinematic_amplification(d.phi1_deg, d.phi2_deg)
    if args.json:
        print_json({"design": d.name, "phi1_deg": d.phi1_deg, "phi2_deg": d.phi2_deg,
                    "feasible": report.feasible, "A_kin": a_kin,
                    "rules": [dataclasses.asdict(r) for r in report.results]})
    else:
        phi2 = "basis (no middle branch)" if d.is_basis else f"phi2 = {d.phi2_deg:g} deg"
        print(f"design {d.name}: phi1 = {d.phi1_deg:g} deg, {phi2}")
        for r in report.results:
            print(f"  {'pass' if r.ok else 'FAIL'}  {r.rule:<16} {r.message}")
        print(f"kinematic amplification A_kin = {a_kin:.3f}")
        print("feasible" if report.feasible else "NOT feasible")
    return 0 if report.feasible else 1
