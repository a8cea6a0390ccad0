"""``dacm solve``: the nonlinear chain-algorithm solve of one design or beam model."""

from __future__ import annotations

import argparse
from pathlib import Path

from sensor.cli.design_args import (
    add_design_arguments,
    check_flags,
    design_from_args,
    travel_rule,
)
from sensor.cli.output import print_json
from sensor.validation import Number, require_finite

#: Rules of the numeric flags (the target travel's depends on the body, see run).
RULES = {"increments": Number(1, 1000, integer=True),
         "target_force": Number(0.0, 1e5, lo_open=True, unit="N")}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "solve", help="solve a design: amplification, k_out, strain energy, hysteresis, quality",
        description="Solve a design (or a JSON beam model) with the iterative nonlinear "
                    "Castigliano chain algorithm to an output travel (default 1 mm) and report "
                    "amplification, output stiffness, sensitivity, strain energy, predicted "
                    "hysteresis (strain-energy law calibrated on the basis specimen) and quality.")
    add_design_arguments(p)
    p.add_argument("--model", type=Path, metavar="JSON",
                   help="solve a beam model written by `dacm export --beam-model` (or any model of "
                        "that schema) instead of a design")
    p.add_argument("--target-output", type=float, metavar="MM",
                   help="stop when the output port has travelled MM (default 1)")
    p.add_argument("--target-force", type=float, metavar="N",
                   help="stop when the input force reaches N instead")
    p.add_argument("--increments", type=int, default=8, metavar="N",
                   help="load increments (default 8; Newton corrections make the result "
                        "independent of it)")
    p.add_argument("--linear", action="store_true",
                   help="the linear limit: solve to a thousandth of the target travel and scale "
                        "forces, travels and strain energy to the target (small-deflection values)")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from geometry.checks import assert_feasible
    from geometry.layout import kinematic_amplification
    from geometry.topology import build_beam_model, load_model
    from sensor.errors import UsageError
    from sensor.mechanics.hysteresis import DEFAULT_LAW
    from sensor.mechanics.qualifiers import qualify
    from geometry.params import cut_note
    from sensor.mechanics.solver import LINEAR_LIMIT_FRACTION, SolverOptions, scaled_result, solve
    from sensor.mechanics.stress import hinge_stresses, stress_check
    from sensor.mechanics.toggle import JSON_KEYS, stroke_change

    check_flags(args, RULES)
    if args.model is not None:
        shape = [f for f in ("design", "phi1", "phi2", "hinges", "preset", "config")
                 if getattr(args, f) is not None]
        if shape:
            raise UsageError(f"--model cannot be combined with --{shape[0]}")
        model, name, a_kin = load_model(args.model), args.model.stem, None
        size = float(np.ptp(model.nodes, axis=0).max())
        design = None
    else:
        design = design_from_args(args)
        assert_feasible(design)
        model, name, size = build_beam_model(design), design.name, design.height_mm
        a_kin = kinematic_amplification(design.phi1_deg, design.phi2_deg)
    check_flags(args, {"target_output": travel_rule(size)})
    target_output = args.target_output if args.target_output is not None or args.target_force is not None else 1.0
    scale = LINEAR_LIMIT_FRACTION if args.linear else 1.0
    r = solve(model, target_output_mm=None if target_output is None else target_output * scale,
              target_force_N=None if args.target_force is None else args.target_force * scale,
              options=SolverOptions(increments=args.increments))
    if args.linear:
        r = scaled_result(r, 1.0 / scale)
    # how much k_out and A change from the linear limit to the state solved (not asked of
    # --linear); a --model has no phi2: only its stroke can mark it as next to the toggle
    change = None if args.linear else stroke_change(model, r, None if design is None else design.phi2_deg,
                                                    SolverOptions(increments=args.increments))
    q = qualify(r, DEFAULT_LAW)
    stress = stress_check(design, model, r) if design is not None else None
    hinge_stress = {str(h): s.peak_MPa for h, s in hinge_stresses(model, r).items()}
    out = {
        "design": name,
        "amplification": r.amplification,
        "A_kin": a_kin,
        "k_out_N_per_mm": r.k_out_N_per_mm,
        "sensitivity_mm_per_N": r.sensitivity_mm_per_N,
        "strain_energy_mJ": r.strain_energy_mJ,
        "input_force_N": r.input_force_N,
        "input_travel_mm": r.input_travel_mm,
        "output_travel_mm": r.output_travel_mm,
        "range_N": q.range_N,
        "hysteresis_predicted": q.hysteresis,
        "quality_mm_per_N": q.quality_mm_per_N,
        "increments": r.increments,
        "residual": r.residual,
        "converged": r.converged,
        "hinge_rotation_deg": {str(k): v for k, v in r.hinge_rotation_deg.items()},
        "linear": bool(args.linear),
        "kerf_mm": None if design is None else design.kerf_mm,
        "hinge_stress_MPa": hinge_stress,
        "peak_stress_MPa": max(hinge_stress.values()),
        "stress_utilisation": None if stress is None else stress.utilisation,
        **(dict.fromkeys(JSON_KEYS) if change is None else change.to_dict()),
    }
    require_finite(f"solve of {name}", out)
    if args.json:
        print_json(out)
        return 0
    rows = [("amplification A", f"{r.amplification:.4f}" + (f"   (A_kin {a_kin:.4f})" if a_kin else "")),
            ("output stiffness k_out", f"{r.k_out_N_per_mm:.4f} N/mm"),
            ("sensitivity", f"{r.sensitivity_mm_per_N:.4f} mm/N"),
            ("strain energy SE", f"{r.strain_energy_mJ:.4f} mJ"),
            ("input force / travel", f"{r.input_force_N:.4f} N / {r.input_travel_mm:.4f} mm"),
            ("output travel", f"{r.output_travel_mm:.4f} mm"),
            ("predicted hysteresis H", f"{q.hysteresis:.4f}  ({DEFAULT_LAW.h_per_mJ:.4f} per mJ, "
                                       f"calibrated on the {DEFAULT_LAW.calibrated_on} specimen)"),
            ("quality sensitivity / H", f"{q.quality_mm_per_N:.3f} mm/N"),
            ("increments / residual", f"{r.increments} / {r.residual:.1e} (converged)"),
            ("hinge rotations", ", ".join(f"{k}: {v:+.2f}" for k, v in r.hinge_rotation_deg.items()) + " deg"),
            ("peak hinge stress", ", ".join(f"{k}: {v:.1f}" for k, v in hinge_stress.items()) + " MPa")]
    if stress is not None:
        rows.append(("stress rule", stress.message + f" (utilisation {stress.utilisation:.2f})"))
    if change is not None:
        rows.append(("from the linear limit", f"k_out x {change.k_out_ratio:.3f}, A x {change.amplification_ratio:.3f}"))
    print(f"{name} ({cut_note(None if design is None else design.kerf_mm)})" + ("  linear limit" if args.linear else ""))
    for k, v in rows:
        print(f"  {k:<26} {v}")
    if change is not None and change.near_toggle:
        print(f"  warning: {change.warning()}")
    return 0
