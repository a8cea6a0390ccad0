"""``dacm verify``: the continuum FE of a design's profile as cut (the design's kerf rounds
every re-entrant corner, DESIGN section 16) beside its beam model."""

from __future__ import annotations

import argparse
import math

from sensor.cli.design_args import add_design_arguments, check_flags, design_from_args, travel_rule
from sensor.cli.output import add_output_arguments, claim, make_out_dir, print_json, staged
from sensor.cli.progress import add_quiet_argument, busy

MESHES = ("coarse", "default", "fine")
#: geometry.topology.INPUT_CONTACT_MM, the reference's punch (not imported here: numpy
#: is heavy for ``dacm --help``; tests/cli/test_verify_cli.py checks it);
#: on a top plate under twice that thick, half the plate (geometry.topology.input_contact_mm).
PUNCH_DEFAULT_MM = 0.5


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "verify", help="continuum FE of the cut profile against the beam model",
        description="Mesh the design's profile as cut (the DXF's outline and holes, every "
                    "re-entrant corner rounded by the jet: r = kerf / 2) with quadratic "
                    "triangles refined in the hinges, solve it in plane stress with the base "
                    "clamped and the input a guided punch (0.5 mm by default), at three meshes (Richardson "
                    "extrapolation), and set amplification, output stiffness, strain energy "
                    "and hinge stresses (one thickness inside each neck, and the peak at its "
                    "root fillets) beside the beam model's.")
    add_design_arguments(p)
    p.add_argument("--target-output", type=float, default=1.0, metavar="MM",
                   help="output travel the results are given at (default 1; linear results "
                        "are scaled to it)")
    p.add_argument("--mesh", default="default", metavar="LEVEL",
                   help=f"finest of the three meshes: {' | '.join(MESHES)} (default: default)")
    p.add_argument("--plane-strain", action="store_true",
                   help="plane strain instead of plane stress (the stiff bound)")
    p.add_argument("--nonlinear", action="store_true",
                   help="geometrically nonlinear (total Lagrangian) to the target travel")
    p.add_argument("--nonlinear-meshes", type=int, default=1, metavar="N",
                   help="with --nonlinear: 1 (default) solves the three meshes linear and the "
                        "coarsest nonlinear, its mesh error taken from the linear study (the "
                        "continuum table's method, a sixth of the time); 3 solves all three nonlinear")
    p.add_argument("--kerf", type=float, metavar="MM",
                   help="cutting kerf: re-entrant corners rounded by a jet of this width "
                        "(default the design's kerf_mm, 0.8; 0: the drawn profile, sharp corners)")
    p.add_argument("--punch-width", type=float, metavar="MM",
                   help=f"width of the punch that pushes the input, at most half the top plate's thickness "
                        f"(default {PUNCH_DEFAULT_MM:g}, or half the plate if thinner than {2 * PUNCH_DEFAULT_MM:g}); next to "
                        "the toggle A grows with it (the contact's compliance is part of the input "
                        "travel), k_out does not")
    add_output_arguments(p, "the stress-field picture <name>-verify.png")
    p.add_argument("--no-plots", action="store_true", help="do not write the picture")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    add_quiet_argument(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from geometry.atomic import save_figure
    from geometry.checks import assert_feasible
    from geometry.params import FIELD_RULES
    from geometry.topology import contact_rule, root_radius_mm
    from sensor.errors import UsageError
    from sensor.mechanics.continuum import verification_to_dict, verify_design
    from sensor.mechanics.plots import stress_field_figure

    if args.mesh not in MESHES:
        raise UsageError(f"--mesh = {args.mesh!r}: must be one of {', '.join(MESHES)}")
    if args.nonlinear_meshes not in (1, 3):
        raise UsageError(f"--nonlinear-meshes = {args.nonlinear_meshes}: must be 1 or 3")
    check_flags(args, {"kerf": FIELD_RULES["kerf_mm"]})
    design = design_from_args(args)
    if args.kerf is not None:
        design = design.replace(kerf_mm=args.kerf)
    check_flags(args, {"target_output": travel_rule(design.height_mm), "punch_width": contact_rule(design)})
    paths = [] if args.no_plots else claim(args, [f"{design.name}-verify.png"])
    assert_feasible(design)
    with busy(f"verify {design.name}: continuum FE at three meshes", args.quiet):
        v = verify_design(design, mesh=args.mesh, plane_strain=args.plane_strain,
                          nonlinear=args.nonlinear, target_output_mm=args.target_output,
                          punch_width_mm=args.punch_width, nonlinear_meshes=args.nonlinear_meshes)
    out = verification_to_dict(v)
    if paths:
        path = paths[0]
        kind = ("plane strain" if args.plane_strain else "plane stress") + (", nonlinear" if args.nonlinear else "")
        title = (f"{design.name} {out['profile']}: continuum FE, {kind}, {args.target_output:g} mm output\n"
                 f"A = {v.fe_summary['amplification']:.3f}, k_out = {v.fe_summary['k_out_N_per_mm']:.3f} N/mm;"
                 f" labels: hinge: stress one t inside the neck (MPa)")
        with staged(args) as stage:
            save_figure(stress_field_figure(v.fe, design, title, v.fe_summary["hinge_stress_MPa"]),
                        stage / path.name, dpi=140)
    if args.json:
        print_json(out, paths and [make_out_dir(args.out) / paths[0].name])
        return 0
    print(f"{design.name} {out['profile']}: continuum FE ({out['mesh']['elements']} quadratic triangles, "
          f"{out['mesh']['elements_across_hinge']:g} across each hinge; input through a "
          f"{out['options']['punch_width_mm']:g} mm punch) against the beam model")
    if out["options"]["nonlinear_meshes"] == 1:
        print("  nonlinear on that mesh, the coarsest of three solved linear: its mesh error is taken "
              "from the linear study")
    unstable = out["beam"].get("unstable")
    print(f"  {'':<24}{'FE':>10}{'beam':>10}{'error %':>9}{'FE mesh error %':>17}")
    for key, label in (("amplification", "amplification A"), ("k_out_N_per_mm", "k_out (N/mm)"),
                       ("strain_energy_mJ", "strain energy (mJ)")):
        beam = f"{'-':>10}{'-':>9}" if unstable else f"{out['beam'][key]:>10.4f}{out['errors_pct'][key]:>+9.2f}"
        print(f"  {label:<24}{out['fe'][key]:>10.4f}{beam}{out['convergence'][key]['error_pct']:>17.3f}")
    if unstable:
        print(f"  beam model: {unstable}")
    sharp = "" if root_radius_mm(design) > 0 else " (sharp corners: singular, grows with the mesh)"
    print("  hinge stress, MPa: one thickness inside the neck (FE / beam / error %); peak von Mises "
          f"at the root (FE{sharp} / beam)")
    for h, fe in out["fe"]["hinge_stress_MPa"].items():
        beam = (f"{'-':>7} / {'-':>6}", f"{'-':>6}") if unstable else (
            f"{out['beam']['hinge_stress_MPa'][h]:7.2f} / {out['errors_pct']['hinge_stress_MPa'][h]:+6.1f}",
            f"{out['beam']['hinge_peak_stress_MPa'][h]:6.1f}")
        print(f"    hinge {h:>2}: {fe:7.2f} / {beam[0]}   peak: "
              f"{out['fe']['hinge_peak_stress_MPa'][h]:6.1f} / {beam[1]}")
    _print_stress_verdict(out, design, args.target_output)
    if not unstable:
        fe, beam, err = out["fe"], out["beam"], out["errors_pct"]
        why = "" if design.is_basis else " (where an error in A starts)"  # the middle branch amplifies it
        move, turn = "knee_outward_per_input", "knee_rotation_per_input_rad_per_mm"
        conv = out["convergence"]
        print(f"  left knee per mm of input{why}, FE / beam: outward {fe[move]:.4f} / {beam[move]:.4f} mm "
              f"({_pct(err[move], '+.2f')}), turn {1e3 * fe[turn]:+.2f} / {1e3 * beam[turn]:+.2f} mrad "
              f"({_pct(err[turn], '+.2f')}); FE mesh error {_pct(conv[move]['error_pct'], '.3f')} "
              f"and {_pct(conv[turn]['error_pct'], '.3f')}")
    if out["stability"] and not out["stability"]["stable"]:
        n = out["stability"]["negative_modes"]
        print(f"  the continuum state at {args.target_output:g} mm is unstable ({n} negative mode{'s' * (n > 1)} "
              "of the tangent stiffness with the punch held): the part sways sideways before this travel")
    if paths:
        print(f"wrote {args.out / paths[0].name}")
    return 0


def _pct(value: float | None, spec: str) -> str:
    """A percentage, or n/a where it is undefined (null in the JSON: a zero reference)."""
    return "n/a" if value is None else f"{value:{spec}} %"


def _print_stress_verdict(out: dict, design, travel_mm: float) -> None:
    """The largest hinge peak against the material's allowable stress, and a warning when the
    part passes it before the travel compared (the material creeps past its allowable
    stress, and yields further on: an elastic model no longer describes the part there)."""
    side = "fe" if out["fe"]["stress_utilisation"] is not None else "beam"
    if out[side].get("stress_utilisation") is None or not math.isfinite(design.material.allowable_stress_MPa):
        return  # no peak to judge (the beam unstable, the FE singular) or no allowable stress
    peak, hinge, util = (out[side][k] for k in ("peak_stress_MPa", "peak_stress_hinge", "stress_utilisation"))
    allow = design.material.allowable_stress_MPa
    where = "FE" if side == "fe" else "beam; sharp corners make the FE's singular"
    print(f"  largest peak at {travel_mm:g} mm ({where}): "
          f"{peak:.1f} MPa at hinge {hinge}, {util:.2f} x the allowable {allow:g} MPa of {design.material.name}")
    if util > 1.0:
        print(f"  warning: the part passes its allowable stress before {travel_mm:g} mm "
              f"({peak:.1f} > {allow:g} MPa): past it the material creeps, then yields; the elastic values above "
              "overstate what the part as cut holds")
