"""Where the beam model's errors sit: each group of parts made rigid in both models.

The beam model takes the base plate as a rigid body, the links, the top plate, the
platform and the knee blocks (two stubs each) as beams, and puts the compliance of the
hinge roots into the hinges (each reaches its root depth past the face,
:func:`geometry.topology.root_depth_mm`).
This study solves the linear continuum of a body on one mesh (``--across`` quadratic
elements across each hinge) as it is, then with one group of parts at a time (knees, side
links, middle links, top plate, platform, base plate) 1000 x stiffer except a rim
``--margin`` mm deep behind their faces (a rigid core to within 0.1 % of its compliance),
then with all of them; the beam model is solved with the same groups' members rigid (the
base plate is rigid in it already). Where a group changes A differently in
the two, the beam model's account of that group (or of the roots in it: the rim keeps
the hinges' roots elastic to ``--margin``, the beam's roots reach 0.09-0.21 mm past a face
for 0.3 mm hinges, 0.48-0.54 mm for a 1.4 mm hinge leaning 22 deg) is where A goes wrong; with
all rigid, what is left is the hinges'. With ``--travel MM`` every solve is instead the
geometrically nonlinear one at that output travel (the continuum's St Venant-Kirchhoff law,
the cores' Lame constants scaled as their stiffness): which group's account makes the beam
model stiffen over the stroke differently from the continuum.

    python -m tests.mechanics.rigid_parts_study [NAME ...] [--margin 0.15] [--across 6] [--travel MM] [--nodes]

About 20 s a body on one core (eight FE solves on one mesh; 4 min for the 12 by default);
with ``--travel 1 --across 3`` about 100 s a solve (like-4, 13 min).
Prints one JSON object per body (percent: the beam model against the continuum; per group,
the change in A and k_out that making it rigid brings in each model, and the beam model
against the continuum with it rigid in both; with ``--nodes`` also both models'
displacements at the beam model's nodes, :func:`node_displacements`) and one for all of them
(mean |error| in A and in k_out). Bodies are names of the continuum table (entries, or drawn cases; a name in
both is the cut-part entry); by default the two linear misses of
tests/mechanics/test_continuum_table.py and ten other bodies.
"""

import argparse
import dataclasses
import json

import numpy as np

from geometry.layout import make_layout, make_parts
from geometry.params import Design, design_from_dict
from geometry.topology import INPUT_CONTACT_MM, BeamModel, build_beam_model, root_radius_mm
from sensor.errors import SolverError
from sensor.mechanics import continuum
from sensor.mechanics.continuum import LINEAR_LIMIT_FRACTION, relative_error_pct
from sensor.mechanics.solver import solve
from tests.mechanics.test_continuum_table import CUT_MISSES, DESIGNS, ENTRIES, LINEAR_MISSES

#: How much stiffer a rigid core is made: its compliance is 0.1 % of the elastic one's.
RIGID_FACTOR = 1000.0
BODIES = (sorted(LINEAR_MISSES) + sorted(CUT_MISSES)
          + ["sample-b-as-cut", "design-5N", "like-1-delrin", "thick-28-20-1.0", "like-5-delrin",
             "like-6-delrin", "like-8-delrin", "05-03-12-10", "03-03-16-20", "05-03-22-6"])
#: Group -> (the continuum's parts, each tuple unioned before its rim is taken off, and the
#: beam model's members of the same parts).
GROUPS = {
    "knees": ((("left knee lower", "left knee upper"), ("right knee lower", "right knee upper")),
              ("left knee", "right knee")),
    "side links": (tuple((f"{s} link",) for s in ("left lower", "left upper", "right upper", "right lower")),
                   ("left lower link", "left upper link", "right upper link", "right lower link")),
    "middle links": ((("left middle link",), ("right middle link",)), ("left middle link", "right middle link")),
    "top plate": ((("top plate left", "top plate right"),), ("top plate left", "top plate right")),
    "platform": ((("platform left", "platform right"),), ("platform left", "platform right")),
    "base plate": ((("base plate",),), ()),
}


def design_of(name: str) -> Design:
    """A continuum-table body by name: a cut-part entry or a drawn case."""
    return design_from_dict(ENTRIES[name]["design"]) if name in ENTRIES else DESIGNS[name]


def cores(polygons: dict, centres: np.ndarray, parts: tuple, margin_mm: float) -> np.ndarray:
    """Which triangles (centres (2, M), mm) lie in the given parts (each a tuple of names of
    ``polygons``, the body's parts, unioned) more than ``margin_mm`` behind their faces."""
    from shapely import contains_xy
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    inside = np.zeros(centres.shape[1], bool)
    for names in parts:
        if all(n in polygons for n in names):   # the basis has no middle links or platform
            core = unary_union([Polygon(polygons[n]) for n in names]).buffer(-margin_mm)
            inside |= contains_xy(core, centres[0], centres[1])
    return inside


def fe_state(pb, travel_mm: float | None = None) -> tuple[np.ndarray, float, float, float]:
    """(displacements, output travel, input travel, input force) of a continuum problem as
    :func:`sensor.mechanics.continuum.verify` solves it: the linear state at 1 mm of input
    travel, or (``travel_mm``) the geometrically nonlinear one at that output travel (mm)."""
    u, out, force = continuum.unit_travel_state(pb)
    if travel_mm is None:
        return u, out, 1.0, force
    # in 4 increments of input travel, as verify's default
    u, travel, force = continuum.nonlinear_to_target(pb, u * travel_mm / out, travel_mm / out, travel_mm, 4)
    return u, -float(pb.out_row @ u), travel, force


def response(state: tuple) -> tuple[float, float]:
    """(A, k_out N/mm) of a continuum state (:func:`fe_state`)."""
    _, out, travel, force = state
    return out / travel, force / out


def node_displacements(pb, state: tuple, model: BeamModel, result) -> list[dict]:
    """The continuum's (``state`` of :func:`fe_state`) and the beam model's displacements
    (mm per mm of output travel) at the beam model's nodes on the left half and the centre
    line, the body as it is: where the two fields part, a member's account differs. (like-4
    at 1 mm, 3 across, stop 57's model: the top plate's centre drops 0.460 mm below its
    ends in the continuum and 0.472 mm in the beam model, per newton 1.2 % more; the knee
    block turns 6 % less in the beam model, its top 0.009 mm further out. On the model
    before the contact's fit on the plate these were 0.454 and 0.513 mm, 5 % more per
    newton.)
    ``result``: the beam model's SolveResult at the same output travel."""
    u, out, _, _ = state
    left = np.flatnonzero(model.nodes[:, 0] <= 1e-9)
    fe = (pb.basis.probes(model.nodes[left].T) @ u).reshape(2, -1).T / out
    beam = (result.deformed_nodes - model.nodes)[left] / result.output_travel_mm
    member = {}
    for name, ends in zip(model.member_name, model.member_nodes.tolist()):
        for i in ends:
            member.setdefault(i, name)
    return [{"node": int(i), "member": member[int(i)], "xy_mm": np.round(model.nodes[i], 3).tolist(),
             "fe": np.round(f, 4).tolist(), "beam": np.round(b, 4).tolist()} for i, f, b in zip(left, fe, beam)]


def beam_result(model: BeamModel, rigid: tuple, travel_mm: float | None = None):
    """The beam model's SolveResult with the named members rigid, in the linear limit or at
    the output travel ``travel_mm``."""
    kinds = tuple("rigid" if n in rigid else k for k, n in zip(model.member_kind, model.member_name))
    return solve(dataclasses.replace(model, member_kind=kinds), target_output_mm=travel_mm or LINEAR_LIMIT_FRACTION)


def beam_response(model: BeamModel, rigid: tuple, travel_mm: float | None = None) -> tuple[float, float]:
    """(A, k_out) of :func:`beam_result`."""
    r = beam_result(model, rigid, travel_mm)
    return r.amplification, r.k_out_N_per_mm


def study(name: str, across: float, margin_mm: float, travel_mm: float | None = None, nodes: bool = False) -> dict:
    from skfem import Basis, asm
    from skfem.models.elasticity import linear_elasticity

    design = design_of(name)
    model = build_beam_model(design)
    points, triangles = continuum.mesh_profile(design, across, INPUT_CONTACT_MM,
                                               2.0 * root_radius_mm(design))
    pb = continuum.body_problem(design, points, triangles, False, INPUT_CONTACT_MM, "bottom edge")
    mesh = pb.basis.mesh
    centres = mesh.p[:, mesh.t].mean(axis=1)
    polygons = {p.name: p.polygon for p in make_parts(make_layout(design))}

    def rigid_fe(core):
        stiff = asm(linear_elasticity(pb.lam, pb.mu), Basis(mesh, pb.basis.elem, intorder=4,
                                                            elements=np.flatnonzero(core)))
        scale = np.where(core, RIGID_FACTOR, 1.0)[:, None]  # per element, for the nonlinear forms
        return response(fe_state(dataclasses.replace(pb, K=pb.K + (RIGID_FACTOR - 1.0) * pb.depth * stiff,
                                                     lam=pb.lam * scale, mu=pb.mu * scale), travel_mm))

    state = fe_state(pb, travel_mm)
    as_is = beam_result(model, (), travel_mm)
    fe, beam = response(state), (as_is.amplification, as_is.k_out_N_per_mm)
    row = {"name": name, "travel_mm": travel_mm or "linear limit", "beam_vs_fe_A_pct": round(relative_error_pct(beam[0], fe[0]), 3),
           "beam_vs_fe_k_out_pct": round(relative_error_pct(beam[1], fe[1]), 3)}
    if nodes:
        row["nodes"] = node_displacements(pb, state, model, as_is)
    every, members = np.zeros(centres.shape[1], bool), ()
    for group, (parts, names) in GROUPS.items():
        core = cores(polygons, centres, parts, margin_mm)
        if not core.any():
            continue
        every, members = every | core, members + names
        try:
            f, b = rigid_fe(core), beam_response(model, names, travel_mm)
        except SolverError as exc:  # a nonlinear path Newton does not follow: say so, go on
            row[group] = {"error": str(exc)}
            continue
        row[group] = {f"{side}_d{q}_pct": round(relative_error_pct(x[i], y[i]), 3)
                      for q, i in (("A", 0), ("k_out", 1)) for side, x, y in (("fe", f, fe), ("beam", b, beam))}
        row[group].update({f"beam_vs_fe_{q}_pct": round(relative_error_pct(b[i], f[i]), 3)
                           for q, i in (("A", 0), ("k_out", 1))})
    try:
        f, b = rigid_fe(every), beam_response(model, members, travel_mm)
    except SolverError as exc:
        row["all rigid"] = {"error": str(exc)}
        return row
    row["all rigid"] = {f"beam_vs_fe_{q}_pct": round(relative_error_pct(b[i], f[i]), 3)
                        for q, i in (("A", 0), ("k_out", 1))}
    return row


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=BODIES)
    parser.add_argument("--margin", type=float, default=0.15, help="elastic rim behind the parts' faces, mm (> 0)")
    parser.add_argument("--across", type=float, default=6.0, help="quadratic elements across each hinge")
    parser.add_argument("--travel", type=float, default=None, metavar="MM",
                        help="solve both models nonlinear at this output travel (default: the linear limit)")
    parser.add_argument("--nodes", action="store_true",
                        help="also both models' displacements at the beam model's nodes (the body as it is)")
    args = parser.parse_args(argv)
    if not args.margin > 0:
        parser.error(f"--margin = {args.margin}: must be > 0 mm (a negative rim would grow the parts)")
    if args.travel is not None and not args.travel > 0:
        parser.error(f"--travel = {args.travel}: must be > 0 mm")
    rows = []
    for name in args.names:
        rows.append(study(name, args.across, args.margin, args.travel, args.nodes))
        print(json.dumps(rows[-1]), flush=True)
    summary = {"bodies": len(rows), "margin_mm": args.margin, "elements_across": args.across,
               "travel_mm": args.travel or "linear limit"}
    for q in ("A", "k_out"):  # the beam model's mean |error|, as is, with each group rigid in both, all rigid
        summary[f"mean_abs_beam_vs_fe_{q}_pct"] = round(float(np.mean([abs(r[f"beam_vs_fe_{q}_pct"]) for r in rows])), 3)
        for group in (*GROUPS, "all rigid"):
            errors = [abs(r[group][f"beam_vs_fe_{q}_pct"]) for r in rows
                      if group in r and "error" not in r[group]]
            key = "all_rigid" if group == "all rigid" else f"{group.replace(' ', '_')}_rigid"
            summary[f"mean_abs_{q}_pct_{key}"] = round(float(np.mean(errors)), 3) if errors else None
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
