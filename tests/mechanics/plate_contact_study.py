"""The top plate under the input's punch, alone: the substructure the beam model's contact
rule (geometry.topology.INPUT_CONTACT_MM, :func:`geometry.topology.contact_compliance`) is
fitted on, as a continuum reference independent of the beam model and of the continuum table.

Half a plate ``h`` deep and ``L`` long past the centre: the mirror plane (x = 0) held in x;
a rigid bonded punch over 0 <= x <= w/2 on the top face held in x and y, as the continuum
reference's punch (sensor.mechanics.continuum.body_problem); a shear of 1 N, parabolic
across the depth, on the far end (x = L). Quadratic triangles (scikit-fem), elements of
0.01 mm at the punch's edge, growing away from it (gmsh; halving them moves the compliance
by under 0.05 %). Its compliance is the end's work-conjugate deflection per newton (unit
depth), given as E b x it.

Beside it, for the same half plate:
* ``beam``: the model's rule, a Timoshenko cantilever (form factor 6/5) from
  CONTACT_START_PER_WIDTH x w to L, plus the contact's compliance (per half the force);
* ``quarter_rule``: the rule it replaced, the cantilever from w/4 and no contact compliance;
* ``beam_theory``: a Timoshenko cantilever from the centre, pushed back evenly over the
  punch, relative to the punch's mean deflection.

    python -m tests.mechanics.plate_contact_study [--spans 3,4,6,8] [--widths 0.25,0.5,1] [--depth 2]

Prints one JSON object per (span, width): the compliances and the errors of the beam ones
against the continuum (percent). About 0.3 s each. Measured (stop 56, h = 2, w = 0.5): the
quarter rule is 6.9 / 4.3 / 2.7 / 2.2 % stiffer than the continuum at L = 3 / 4 / 6 / 8
mm; beam theory under an even pressure is 1.3 / 3.0 / 2.8 / 2.2 % softer: the rigid bonded
punch stiffens the plate under it, and the punch sinks into it. The model's rule is -0.3 /
-0.4 / -0.8 / -0.9 %.
"""

import argparse
import json
import math

import numpy as np

from geometry.topology import CONTACT_START_PER_WIDTH, contact_compliance
from sensor.mechanics.solver import SHEAR_FORM_FACTOR, cantilever_flexibility
from tests.mechanics.hinge_substructure import E_MPA, G_MPA, plane_stress_polygon


def fe_compliance(span_mm: float, width_mm: float, depth_mm: float, h_min: float = 0.01) -> float:
    """E b x the continuum's end deflection per newton (see the module docstring)."""
    from skfem import FacetBasis, LinearForm, asm, condense, solve

    L, a, h = span_mm, width_mm / 2, depth_mm

    def size(x, y):
        return float(min(h_min + 0.3 * min(math.hypot(x - a, y - h), math.hypot(x, y - h)), h / 6))

    mesh, basis, K = plane_stress_polygon("plate", ((0, 0), (L, 0), (L, h), (a, h), (0, h)), size)
    tol = 1e-7
    mirror = basis.get_dofs(mesh.facets_satisfying(lambda x: x[0] < tol, boundaries_only=True))
    punch = basis.get_dofs(mesh.facets_satisfying(lambda x: (x[1] > h - tol) & (x[0] < a + tol),
                                                  boundaries_only=True))
    held = np.unique(np.concatenate([mirror.nodal["u^1"], mirror.facet["u^1"], punch.all()]))
    end = FacetBasis(mesh, basis.elem, facets=mesh.facets_satisfying(lambda x: x[0] > L - tol,
                                                                     boundaries_only=True), intorder=6)

    @LinearForm
    def shear(v, p):
        return 1.5 / h * (1 - (2 * (p.x[1] - h / 2) / h) ** 2) * v[1]

    f = asm(shear, end)
    return float(f @ solve(*condense(K, f, D=held))) * E_MPA


def beam_compliance(length_mm: float, depth_mm: float) -> float:
    """E b x a Timoshenko cantilever's tip deflection per newton (unit depth): the solver's
    own member (sensor.mechanics.solver.cantilever_flexibility)."""
    return E_MPA * float(cantilever_flexibility(length_mm, depth_mm, 1.0, E_MPA, G_MPA)[1, 1])


def beam_theory_compliance(span_mm: float, width_mm: float, depth_mm: float, n: int = 200_001) -> float:
    """E b x the end deflection of a Timoshenko cantilever held at the centre and pushed back
    evenly over 0..w/2, relative to the mean deflection there, per newton (trapezoidal
    integration on ``n`` points)."""
    from scipy.integrate import cumulative_trapezoid

    L, a, h = span_mm, width_mm / 2, depth_mm
    x = np.linspace(0.0, L, n)
    shear = np.clip(x / a, 0.0, 1.0)                            # the end's 1 N, less the punch's part
    moment = cumulative_trapezoid(shear[::-1], x, initial=0.0)[::-1]  # about x, from the end
    slope = cumulative_trapezoid(moment / (E_MPA * h**3 / 12), x, initial=0.0) + SHEAR_FORM_FACTOR * shear / (G_MPA * h)
    w = cumulative_trapezoid(slope, x, initial=0.0)
    under = x <= a                                              # the punch's mean deflection: work-conjugate
    return float(w[-1] - np.trapezoid(w[under], x[under]) / a) * E_MPA


def study(span_mm: float, width_mm: float, depth_mm: float) -> dict:
    fe = fe_compliance(span_mm, width_mm, depth_mm)
    rule = (beam_compliance(span_mm - CONTACT_START_PER_WIDTH * width_mm, depth_mm)
            + 2 * contact_compliance(width_mm, depth_mm))   # the half plate carries half the force
    quarter = beam_compliance(span_mm - width_mm / 4, depth_mm)
    theory = beam_theory_compliance(span_mm, width_mm, depth_mm)
    return {"span_mm": span_mm, "width_mm": width_mm, "depth_mm": depth_mm, "fe": round(fe, 4),
            "beam": round(rule, 4), "quarter_rule": round(quarter, 4), "beam_theory": round(theory, 4),
            **{f"{k}_error_pct": round(100 * (v / fe - 1), 2)
               for k, v in (("beam", rule), ("quarter_rule", quarter), ("beam_theory", theory))}}


#: The cases the rule is fitted on (tests/mechanics/test_plate_contact.py): half-spans (mm),
#: punch widths (mm), plate depths (mm)
FIT_CASES = tuple((L, w, h) for h, spans, widths in ((2.0, (3, 4, 6, 8), (0.1, 0.25, 0.5, 1.0)),
                                                     (1.5, (3, 5, 8), (0.25, 0.5, 1.0)),
                                                     (3.0, (4, 6, 8), (0.25, 0.5, 1.0)))
                  for L in map(float, spans) for w in widths)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--spans", default="2,3,4,6,8")
    p.add_argument("--widths", default="0.25,0.5,1")
    p.add_argument("--depth", type=float, default=2.0)
    args = p.parse_args(argv)
    for span in map(float, args.spans.split(",")):
        for width in map(float, args.widths.split(",")):
            print(json.dumps(study(span, width, args.depth)), flush=True)


if __name__ == "__main__":
    main()
