"""``dacm design``: the body of a given force range with the lowest predicted hysteresis
(:mod:`sensor.design_space.optimise`), beside the best basis body of the same range, with its
tolerance report as cut (:mod:`sensor.design_space.tolerance`), optionally the robust design
(:mod:`sensor.design_space.robust`) and the continuum check, and the files to cut it from."""

from __future__ import annotations

import argparse

from sensor.cli.output import add_output_arguments, claim, print_json, staged
from sensor.cli.progress import add_quiet_argument, busy
from sensor.design_space.design_files import FILES, body_lines, write_design_files

#: The files written to --out (basis.toml when a basis body reaches the range).
FLAGS = {"range_N": "--range", "travel_mm": "--travel", "hinge_min_mm": "--hinge-min",
         "hinge_max_mm": "--hinge-max", "min_yield": "--min-yield", "seed": "--seed", "kerf": "--kerf",
         "draws": "--draws", "off_toggle": "--off-toggle"}
KEYS = ("design", "range_N", "hysteresis", "resolution_N", "amplification", "k_out_N_per_mm",
        "strain_energy_mJ", "stress_utilisation", "k_out_stroke_ratio", "amplification_stroke_ratio",
        "near_toggle")


def register(subparsers) -> None:
    from geometry.process import WATER_JET

    p = subparsers.add_parser(
        "design", help="optimise a body for a force range: lowest hysteresis within every rule",
        description="Find the proposed DACM whose range (input force at the output travel) is "
                    "N within 1 %% and whose predicted hysteresis is lowest, subject to every "
                    "feasibility rule, the hinge bounds, the allowable hinge stress at full "
                    "scale and the hysteresis law's domain (H below 0.5, H_LIMIT); phi1, phi2 and the thickness of each mirror-symmetric hinge pair vary "
                    "(multi-start SLSQP with the range as an equality constraint). Prints it "
                    "beside the best basis body of the same range, with the tolerance report of "
                    "the parts cut from it, and writes OUT/design.toml (for --config), its "
                    "datasheet, tolerance report, profile, dimensioned drawing, kerf-compensated "
                    "DXF and OUT/basis.toml.")
    p.add_argument("--range", type=float, required=True, metavar="N", dest="range_N",
                   help="full-scale force, N (the force that moves the mirror over --travel)")
    p.add_argument("--travel", type=float, default=1.0, metavar="MM",
                   help="mirror travel at full scale, mm (default 1; below the fiber clearance)")
    p.add_argument("--hinge-min", type=float, metavar="MM",
                   help=f"thinnest drawn hinge, mm (default the process minimum, {WATER_JET.min_drawn_hinge_mm:g})")
    p.add_argument("--hinge-max", type=float, metavar="MM",
                   help="thickest hinge, mm (default 0.4 x the link width, 0.8)")
    p.add_argument("--robust", action="store_true",
                   help="also the robust design: lowest median H of the parts as cut with "
                        "P(stress > allowable) <= 5 %%, range 5-95 %% band inside +-10 %%, --min-yield and median H < 0.5")
    p.add_argument("--min-yield", type=float, default=0.9, metavar="Y",
                   help="with --robust: least fraction of parts with every hinge >= min_feature_mm (default 0.9)")
    p.add_argument("--draws", type=int, default=200, metavar="N",
                   help="Monte Carlo draws of the tolerance report (default 200)")
    p.add_argument("--kerf", type=float, default=WATER_JET.kerf_mm, metavar="MM",
                   help=f"jet width the DXF is compensated for, mm (default the process kerf, {WATER_JET.kerf_mm:g}; "
                        "0: the drawn profile)")
    p.add_argument("--off-toggle", action="store_true",
                   help="keep the DACM off the toggle (phi2 >= 12 deg, k_out growing at most 2.2 x and A "
                        "falling to no less than 0.8 x over the stroke), where the beam model's full-scale "
                        "numbers have held against the continuum; H is higher (+15 %% at 10 N, +39 %% at 15 N)")
    p.add_argument("--verify", action="store_true",
                   help="also the continuum FE check of the result (nonlinear, at full scale)")
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument("--workers", type=int, default=0, metavar="N",
                   help="local processes (default: one per core; 1 = serial)")
    p.add_argument("--scheduler", metavar="ADDRESS", help="run on this Dask distributed scheduler")
    add_output_arguments(p, "design.toml, its datasheet, tolerance report, drawing, DXF, basis.toml")
    add_quiet_argument(p)
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(func=run)


def _check_args(args) -> None:
    from geometry.params import FIELD_RULES
    from sensor.errors import DesignError
    from sensor.validation import Number

    FIELD_RULES["kerf_mm"].check("kerf", args.kerf, DesignError)
    Number(0.0, 1.0, lo_open=True, hi_open=True).check("min_yield", args.min_yield, DesignError)
    Number(10, 100_000, integer=True).check("draws", args.draws, DesignError)


def run(args: argparse.Namespace) -> int:
    from geometry.checks import check_design
    from geometry.params import cut_note, load_design
    from sensor.design_space.execution import task_pool
    from sensor.design_space.optimise import DesignProblem, accept, describe, optimise
    from sensor.design_space.robust import robust
    from sensor.design_space.tolerance import tolerance, tolerance_text
    from sensor.errors import DesignError

    kw = dict(range_N=args.range_N, travel_mm=args.travel, hinge_min_mm=args.hinge_min,
              hinge_max_mm=args.hinge_max, seed=args.seed)
    try:
        _check_args(args)
        problem = DesignProblem(**kw, off_toggle=args.off_toggle)
        basis_problem = DesignProblem(**kw, body="basis")
    except DesignError as exc:
        raise DesignError(_flagged(str(exc))) from None
    claim(args, FILES, exclusive=True)
    tag = f"{args.range_N:g}N".replace("+", "")
    with task_pool(args.workers, args.scheduler) as pool, busy(f"design {args.range_N:g} N", args.quiet) as step:
        try:
            step("the DACM")
            best = optimise(problem, pool, name=f"design-{tag}")
        except DesignError as exc:
            raise DesignError(_flagged(str(exc))) from None
        try:
            step("the basis body of the same range")
            basis, no_basis = optimise(basis_problem, pool, name=f"basis-{tag}"), ""
        except DesignError as exc:   # a DACM may reach ranges no basis body does
            basis, no_basis = None, _flagged(str(exc))
        step("the tolerance report")
        nominal_tol = tolerance(best.design, problem.process, args.draws, args.seed, args.travel, problem.law)
        rob = None
        if args.robust:
            step("the robust design")
            rob = robust(problem, best.design, args.draws, args.seed, args.min_yield, name=f"design-{tag}-robust",
                         pool=pool)
        verification = None
        if args.verify:
            from sensor.mechanics.continuum import verify_design
            step("the continuum check")
            verification = verify_design(rob.design if rob else best.design, nonlinear=True,
                                         target_output_mm=args.travel)
    design = rob.design if rob else best.design
    tol = rob.tolerance if rob else nominal_tol
    ours = describe(design, problem)
    theirs = None if basis is None else describe(basis.design, basis_problem)
    with staged(args) as stage:
        names = write_design_files(stage, design, None if basis is None else basis.design, ours["datasheet"],
                                   tol.to_dict(), args.kerf)
    paths = {name: args.out / name for name in names}
    # the written files, read back, must keep every rule
    # (the robust design's drawn range is not N: its parts' median is; it keeps the rules)
    for path, prob in ((paths["design.toml"], problem), (paths.get("basis.toml"), basis_problem)):
        if path is None:
            continue
        back = load_design(path)
        fail = check_design(back).first_failure
        ok, why = (fail is None, "" if fail is None else fail.message) if rob and prob is problem else accept(prob, back)
        if not ok:
            raise DesignError(f"{path}: the written design fails its check ({why}); please report it")
    out = {k: ours[k] for k in KEYS}
    out["tolerance"] = tol.to_dict()
    if rob:
        nominal = describe(best.design, problem)
        out["nominal"] = {**{k: nominal[k] for k in KEYS}, "tolerance": nominal_tol.to_dict()}
        out["robust"] = {"constraints_met": rob.met, "why_not": rob.why, "seconds": rob.seconds}
    if verification is not None:
        from sensor.mechanics.continuum import verification_to_dict
        out["verify"] = verification_to_dict(verification)
    out["off_toggle"] = args.off_toggle
    out.update(basis=None if basis is None else {k: theirs[k] for k in KEYS},
               evaluations=best.evaluations + (basis.evaluations if basis else 0),
               seconds=best.seconds + (basis.seconds if basis else 0.0), files=[str(p) for p in paths.values()])
    if basis is None:
        out["basis_unreachable"] = no_basis
    if args.json:
        print_json(out, list(paths.values()))
        return 0
    print(f"range {args.range_N:g} N at {args.travel:g} mm travel ({cut_note(design.kerf_mm)}"
          f"{'; off the toggle' if args.off_toggle else ''}): "
          f"{out['evaluations']} bodies evaluated in {out['seconds']:.1f} s")
    rows = [("DACM" + (" robust" if rob else ""), ours)]
    if rob:
        rows.append(("DACM nominal", nominal))
    if theirs:
        rows.append(("basis", theirs))
    for label, d in rows:
        print("\n".join(body_lines(label, d)))
    if ours["near_toggle"] and not args.off_toggle:
        print("               (--off-toggle finds the best DACM off the toggle, at a higher H)")
    if theirs:
        print(f"  DACM / basis: H {ours['hysteresis'] / theirs['hysteresis']:.3f} (1/A = {1 / ours['amplification']:.3f}), "
              f"resolution {ours['resolution_N'] / theirs['resolution_N']:.3f}")
    else:
        print(f"  basis: {no_basis}")
    for line in tolerance_text(tol):
        print("  " + line)
    if rob:
        print("  nominal design " + tolerance_text(nominal_tol)[1].strip() + "; "
              + tolerance_text(nominal_tol)[2].strip())
        print(f"  robust constraints: {'met' if rob.met else 'NOT met: ' + rob.why}")
    if verification is not None:
        e = verification.errors_pct
        print(f"  continuum check (nonlinear, {args.travel:g} mm): " + (
            f"beam vs FE k_out {e['k_out_N_per_mm']:+.1f} %, A {e['amplification']:+.1f} %, "
            f"SE {e['strain_energy_mJ']:+.1f} %" if e else f"beam model {verification.beam['unstable']}")
            + ("" if verification.fe.stable else "; the FE state there is UNSTABLE (the part sways sideways)"))
    for p in paths.values():
        print(f"wrote {p}")
    return 0


def _flagged(message: str) -> str:
    """A library message with its fields named as the flags that set them."""
    from sensor.cli.design_args import flagged

    return flagged(message, FLAGS)
