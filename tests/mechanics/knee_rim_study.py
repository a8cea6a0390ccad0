"""Where the beam model's errors in A sit: the continuum with its knee blocks made rigid.

The beam model takes each knee block as a rigid body and puts the compliance of the hinge
roots in it into the hinges (each reaches its root depth past the face,
:func:`geometry.topology.root_depth_mm`). This study solves the linear continuum of a body
twice on one mesh (``--across`` quadratic elements across each hinge): as it is, and
with both knee blocks, all but a rim ``--margin`` mm deep behind their faces, 1000 x stiffer
(a rigid block to within 0.1 % of its compliance). Where the beam model's error in A shrinks
against the rigid-knee continuum, part of it goes with the knees' compliance round their
roots. Not like for like: the beam model keeps its roots' depth into the knees (0.51 mm for
a 1.4 mm hinge leaning 22 deg), which the rigid core removes, so it says where to look, not
what the root rule lacks.

    python -m tests.mechanics.knee_rim_study [NAME ...] [--margin 0.15] [--across 6]

About 15 s a body on one core (two FE solves; 4 min for the 13 by default). Prints one JSON
object per body (percent: the knee's effect on the continuum, and the beam model against
both continua) and one for all of them. Bodies are names of the continuum table (entries, or
drawn cases; a name in both is the cut-part entry); by default the three linear misses of
tests/mechanics/test_continuum_table.py and ten other bodies.
"""

import argparse
import dataclasses
import json

import numpy as np

from geometry.layout import make_layout, make_parts
from geometry.params import Design, design_from_dict
from geometry.topology import build_beam_model, root_radius_mm
from sensor.mechanics import continuum
from sensor.mechanics.continuum import LINEAR_LIMIT_FRACTION, relative_error_pct
from sensor.mechanics.solver import solve
from tests.mechanics.test_continuum_table import CUT_MISSES, DESIGNS, ENTRIES, LINEAR_MISSES

#: How much stiffer the knees' cores are made: their compliance is 0.1 % of the elastic one's.
RIGID_FACTOR = 1000.0
BODIES = (sorted(LINEAR_MISSES) + sorted(CUT_MISSES)
          + ["sample-b-as-cut", "design-5N", "like-1-delrin", "thick-28-20-1.0", "like-5-delrin",
             "like-6-delrin", "like-8-delrin", "05-03-12-10", "03-03-16-20", "05-03-22-6"])


def design_of(name: str) -> Design:
    """A continuum-table body by name: a cut-part entry or a drawn case."""
    return design_from_dict(ENTRIES[name]["design"]) if name in ENTRIES else DESIGNS[name]


def knee_cores(design: Design, centres: np.ndarray, margin_mm: float) -> np.ndarray:
    """Which triangles (centres (2, M), mm) lie in a knee block more than ``margin_mm``
    behind its faces."""
    from shapely import contains_xy
    from shapely.geometry import Polygon

    inside = np.zeros(centres.shape[1], bool)
    for part in make_parts(make_layout(design)):
        if part.name.endswith(" knee"):
            core = Polygon(part.polygon).buffer(-margin_mm)
            inside |= contains_xy(core, centres[0], centres[1])
    return inside


def linear_response(pb) -> tuple[float, float]:
    """(A, k_out N/mm) of a continuum problem in the linear limit, as
    :func:`sensor.mechanics.continuum.verify` reads them: the punch pushed 1 mm."""
    idx, val = continuum._prescribed(pb, 1.0)
    u = continuum._solve_dirichlet(pb.K, np.zeros(pb.K.shape[0]), idx, val)
    out = -float(pb.out_row @ u)
    return out, -float((pb.K @ u)[pb.punch_y].sum()) / out


def linear_fe(design: Design, across: float, margin_mm: float) -> tuple[tuple, tuple]:
    """(A, k_out) of the linear continuum on one mesh (``across`` elements across each hinge)
    as it is, and with the knees' cores (``margin_mm`` behind their faces) made rigid."""
    from skfem import Basis, asm
    from skfem.models.elasticity import linear_elasticity

    points, triangles = continuum.mesh_profile(design, across, continuum.PUNCH_WIDTH_MM, 2.0 * root_radius_mm(design))
    pb = continuum._problem(design, points, triangles, False, continuum.PUNCH_WIDTH_MM, "bottom edge")
    mesh = pb.basis.mesh
    core = np.flatnonzero(knee_cores(design, mesh.p[:, mesh.t].mean(axis=1), margin_mm))
    stiff = asm(linear_elasticity(pb.lam, pb.mu), Basis(mesh, pb.basis.elem, intorder=4, elements=core))
    rigid = dataclasses.replace(pb, K=pb.K + (RIGID_FACTOR - 1.0) * pb.depth * stiff)
    return linear_response(pb), linear_response(rigid)


def study(name: str, across: float, margin_mm: float) -> dict:
    design = design_of(name)
    r = solve(build_beam_model(design), target_output_mm=LINEAR_LIMIT_FRACTION)
    beam = (r.amplification, r.k_out_N_per_mm)
    elastic, rigid = linear_fe(design, across, margin_mm)
    row = {"name": name}
    for i, q in enumerate(("A", "k_out")):
        row[f"rigid_knee_vs_elastic_{q}_pct"] = round(relative_error_pct(rigid[i], elastic[i]), 3)
        row[f"beam_vs_elastic_{q}_pct"] = round(relative_error_pct(beam[i], elastic[i]), 3)
        row[f"beam_vs_rigid_knee_{q}_pct"] = round(relative_error_pct(beam[i], rigid[i]), 3)
    return row


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", default=BODIES)
    parser.add_argument("--margin", type=float, default=0.15, help="elastic rim behind the knees' faces, mm (> 0)")
    parser.add_argument("--across", type=float, default=6.0, help="quadratic elements across each hinge")
    args = parser.parse_args(argv)
    if not args.margin > 0:
        parser.error(f"--margin = {args.margin}: must be > 0 mm (a negative rim would grow the knees)")
    rows = []
    for name in args.names:
        rows.append(study(name, args.across, args.margin))
        print(json.dumps(rows[-1]), flush=True)
    before = [abs(r["beam_vs_elastic_A_pct"]) for r in rows]
    after = [abs(r["beam_vs_rigid_knee_A_pct"]) for r in rows]
    print(json.dumps({"bodies": len(rows), "margin_mm": args.margin, "elements_across": args.across,
                      "A_error_shrinks_on": sum(a < b for a, b in zip(after, before)),
                      "mean_abs_A_error_pct": {"elastic_knees": round(float(np.mean(before)), 3),
                                               "rigid_knees": round(float(np.mean(after)), 3)}}))


if __name__ == "__main__":
    main()
