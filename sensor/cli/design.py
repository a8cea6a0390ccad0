"""``dacm design``: the body of a given force range with the lowest predicted hysteresis
(:mod:`sensor.design_space.optimise`), beside the best basis body of the same range."""

from __future__ import annotations

import argparse
import json

from sensor.cli.output import add_output_arguments, claim, make_out_dir, print_json
from sensor.cli.parser import add_target_output_argument
from sensor.cli.progress import add_quiet_argument, busy

#: The files written to --out.
FILES = ("design.toml", "design-datasheet.json", "design-profile.png", "basis.toml")
#: Library field -> flag, for the one-line errors.
FLAGS = {"range_N": "--range", "target_output_mm": "--target-output", "hinge_min_mm": "--hinge-min",
         "hinge_max_mm": "--hinge-max", "robust_sd_mm": "--robust", "min_yield": "--min-yield",
         "seed": "--seed"}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "design", help="optimise a body for a force range: lowest hysteresis within every rule",
        description="Find the proposed DACM whose range (input force at the output travel) is "
                    "N within 1 %% and whose predicted hysteresis is lowest, subject to every "
                    "feasibility rule and the allowable hinge stress at full scale; phi1, phi2 "
                    "and the thickness of each mirror-symmetric hinge pair vary (differential "
                    "evolution, then a Powell search). Prints it beside the best basis body of "
                    "the same range and writes OUT/design.toml (for --config), its datasheet, "
                    "its profile picture and OUT/basis.toml.")
    p.add_argument("--range", type=float, required=True, metavar="N", dest="range_N",
                   help="full-scale force, N (the force that moves the mirror over --target-output)")
    add_target_output_argument(p, "mirror travel at full scale, mm (default 1; below the fiber clearance)",
                               old="--travel", default=1.0)
    p.add_argument("--hinge-min", type=float, metavar="MM",
                   help="thinnest hinge, mm (default the process' min_feature_mm, 0.25)")
    p.add_argument("--hinge-max", type=float, metavar="MM",
                   help="thickest hinge, mm (default the link width, 2)")
    p.add_argument("--robust", type=float, default=0.0, metavar="SD",
                   help="maximise the 10th-percentile quality under hinge scatter of SD mm instead")
    p.add_argument("--min-yield", type=float, default=0.9, metavar="Y",
                   help="with --robust: least fraction of draws that can be cut (default 0.9)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument("--workers", type=int, default=0, metavar="N",
                   help="local processes (default: one per core; 1 = serial)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on this Dask distributed scheduler")
    add_output_arguments(p, "design.toml, its datasheet and profile, basis.toml")
    add_quiet_argument(p)
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from geometry.atomic import atomic_path, save_figure
    from geometry.drawing import profile_figure
    from geometry.params import save_design
    from sensor.design_space.execution import task_pool
    from sensor.design_space.optimise import DesignProblem, describe, optimise
    from sensor.errors import DesignError

    kw = dict(range_N=args.range_N, target_output_mm=args.target_output, hinge_min_mm=args.hinge_min,
              hinge_max_mm=args.hinge_max, robust_sd_mm=args.robust, min_yield=args.min_yield, seed=args.seed)
    try:
        problem = DesignProblem(**kw)
        basis_problem = DesignProblem(**{**kw, "robust_sd_mm": 0.0}, body="basis")
    except DesignError as exc:
        raise DesignError(_flagged(str(exc))) from None
    claim(args, FILES)
    with task_pool(args.workers, args.scheduler) as pool, busy(f"design {args.range_N:g} N", args.quiet) as step:
        try:
            step("the DACM")
            best = optimise(problem, pool)
        except DesignError as exc:
            raise DesignError(_flagged(str(exc))) from None
        try:
            step("the basis body of the same range")
            basis, no_basis = optimise(basis_problem, pool), ""
        except DesignError as exc:   # a DACM may reach ranges no basis body does
            basis, no_basis = None, str(exc)
    tag = f"{args.range_N:g}N".replace("+", "")
    design = rounded(best.best.design, f"design-{tag}" + ("-robust" if args.robust else ""))
    basis_design = None if basis is None else rounded(basis.best.design, f"basis-{tag}")
    ours = describe(design, problem)
    theirs = None if basis is None else describe(basis_design, basis_problem)
    make_out_dir(args.out)
    paths = [args.out / f for f in FILES[:3 if basis is None else 4]]
    save_design(design, paths[0])
    with atomic_path(paths[1]) as tmp:
        tmp.write_text(json.dumps(ours["datasheet"], indent=1))
    save_figure(profile_figure(design), paths[2])
    if basis is not None:
        save_design(basis_design, paths[3])
    keys = ("design", "range_N", "hysteresis", "resolution_N", "amplification", "k_out_N_per_mm",
            "strain_energy_mJ", "stress_utilisation")
    out = {k: ours[k] for k in keys}
    if args.robust:
        out.update(quality_p10_mm_per_N=best.best.quality_p10_mm_per_N, yield_fraction=best.best.yield_fraction)
    out.update(basis=None if basis is None else {k: theirs[k] for k in keys},
               evaluations=best.evaluations + (basis.evaluations if basis else 0),
               seconds=best.seconds + (basis.seconds if basis else 0.0), files=[str(p) for p in paths])
    if basis is None:
        out["basis_unreachable"] = no_basis
    else:  # the ratios the text prints
        out.update(hysteresis_ratio=ours["hysteresis"] / theirs["hysteresis"], inverse_amplification=1 / ours["amplification"],
                   resolution_ratio=ours["resolution_N"] / theirs["resolution_N"])
    if args.json:
        print_json(out, paths)
        return 0
    print(f"range {args.range_N:g} N at {args.target_output:g} mm travel: {out['evaluations']} bodies evaluated "
          f"in {out['seconds']:.1f} s")
    for label, d in (("DACM", ours), ("basis", theirs)) if theirs else (("DACM", ours),):
        f = d["design"]
        angles = f"phi1 = {f['phi1_deg']:.2f}" + (f", phi2 = {f['phi2_deg']:.2f}" if "phi2_deg" in f else "")
        print(f"  {label:<6} {angles} deg, hinges {' '.join(f'{t:.3f}' for t in f['hinge_thickness_mm'][:12 if label == 'DACM' else 8])} mm")
        print(f"         range {d['range_N']:.4f} N, H = {d['hysteresis']:.4f}, resolution {1e3 * d['resolution_N']:.3f} mN, "
              f"A = {d['amplification']:.3f}, k_out {d['k_out_N_per_mm']:.3f} N/mm, SE {d['strain_energy_mJ']:.4f} mJ, "
              f"stress {d['stress_utilisation']:.2f} x allowable")
    if theirs:
        print(f"  DACM / basis: H {out['hysteresis_ratio']:.3f} (1/A = {out['inverse_amplification']:.3f}), "
              f"resolution {out['resolution_ratio']:.3f}")
    else:
        print(f"  basis: {no_basis}")
    if args.robust:
        print(f"  robust: 10th-percentile quality {out['quality_p10_mm_per_N']:.2f} mm/N, "
              f"{100 * out['yield_fraction']:.0f} % of the draws can be cut")
    for p in paths:
        print(f"wrote {p}")
    return 0


def rounded(design, name: str):
    """The design as it is written: angles to 0.01 deg, hinges to 0.1 um (the range moves
    by well under 0.1 %; every number printed is of this design)."""
    return design.replace(phi1_deg=round(design.phi1_deg, 2), name=name,
                          phi2_deg=None if design.is_basis else round(design.phi2_deg, 2),
                          hinge_thickness_mm=tuple(round(t, 4) for t in design.hinge_thickness_mm))


def _flagged(message: str) -> str:
    """A library message with its fields named as the flags that set them."""
    for field, flag in FLAGS.items():
        message = message.replace(f"{field} = ", f"{flag} = ")
    return message
