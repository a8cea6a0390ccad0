"""Regenerate tests/mechanics/data/continuum_table.json: the continuum FE reference of the
beam model (DESIGN section 14), on the drawn (DXF) profile in plane stress.

For every case: the linear limit from three meshes (6, 8.49 and 12 quadratic elements
across each hinge) with Richardson extrapolation and, for the cases in NONLINEAR, the
geometrically nonlinear solve at 1 mm output travel on the default mesh (6 across). Takes
about 20 minutes on one core:

    python -m tests.mechanics.make_continuum_table [--only NAME ...]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from geometry.params import make_design, preset
from sensor.mechanics.continuum import convergence_study, verify

TABLE = Path(__file__).with_name("data") / "continuum_table.json"

PRESETS = ("basis", "sample-a", "sample-b", "basis-as-cut", "sample-a-as-cut", "sample-b-as-cut")
#: Sweep cells (hinge set, phi1, phi2): both hinge sets, the whole phi1 range, and cells next
#: to the toggle (small phi2, where amplification peaks and then collapses).
CELLS = (("05-03", 8, 20), ("05-03", 12, 10), ("05-03", 16, 35), ("05-03", 22, 6),
         ("05-03", 28, 10), ("05-03", 31, 35),
         ("03-03", 8, 50), ("03-03", 12, 4), ("03-03", 16, 20), ("03-03", 22, 10),
         ("03-03", 28, 6), ("03-03", 31, 35))
NONLINEAR = ("basis", "sample-a", "sample-b", "sample-b-as-cut", "05-03-22-6", "03-03-28-6")


def cases():
    out = {name: preset(name) for name in PRESETS}
    for h, p1, p2 in CELLS:
        name = f"{h}-{p1}-{p2}"
        out[name] = make_design(p1, p2, h, name=name)
    return out


def fe_case(design, nonlinear: bool) -> dict:
    runs, conv = convergence_study(design, mesh="fine")
    fine = runs[-1]
    row = {"linear": {q: {"levels": list(c.values), "order": c.order, "extrapolated": c.extrapolated,
                          "error_pct": c.error_pct} for q, c in conv.items()},
           "elements_across": [r.elements_across for r in runs],
           "hinge_neck_stress_MPa": {str(k): v for k, v in fine.hinge_neck_stress_MPa.items()},
           "hinge_peak_stress_MPa_sharp": {str(k): v for k, v in fine.hinge_stress_MPa.items()}}
    if nonlinear:
        r = verify(design, mesh="default", nonlinear=True)
        row["nonlinear_1mm_default_mesh"] = {
            "amplification": r.amplification, "k_out_N_per_mm": r.k_out_N_per_mm,
            "strain_energy_mJ": r.strain_energy_mJ,
            "hinge_neck_stress_MPa": {str(k): v for k, v in r.hinge_neck_stress_MPa.items()}}
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", help="recompute only these cases (others kept)")
    args = ap.parse_args()
    table = json.loads(TABLE.read_text()) if TABLE.exists() else {}
    table["about"] = ("continuum FE (sensor.mechanics.continuum), drawn profile, plane stress, "
                      "base bottom edge clamped, guided 0.5 mm punch; linear values scaled to "
                      "1 mm output travel")
    table.setdefault("cases", {})
    for name, design in cases().items():
        if args.only and name not in args.only:
            continue
        t0 = time.time()
        table["cases"][name] = fe_case(design, name in NONLINEAR)
        print(f"{name}: {time.time() - t0:.0f} s", flush=True)
        TABLE.write_text(json.dumps(table, indent=1) + "\n")


if __name__ == "__main__":
    main()
