"""The README's headline table: `dacm design`'s answers at 1, 2, 5, 10 and 15 N (delrin, 1 mm
travel, the water-jet process), nominal and robust, proposed and basis body, each with the
tolerance report of the parts cut from it (200 draws, seed 0) and whether it sits next to
the toggle (sensor/mechanics/toggle.py); where the proposed body's nominal answer does, also
the nominal answer of ``dacm design --off-toggle``. Rewrites the block between the
``design-table`` markers of README.md and writes docs/design-table.json.

    python examples/design_table.py [--workers N]

About 10 min on an idle 2-core machine (22 searches; the robust ones dominate).
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

from sensor.design_space.execution import task_pool
from sensor.design_space.optimise import DesignProblem, optimise
from sensor.design_space.robust import robust
from sensor.design_space.tolerance import tolerance
from sensor.errors import DesignError

ROOT = Path(__file__).resolve().parents[1]
RANGES_N = (1.0, 2.0, 5.0, 10.0, 15.0)
START, END = "<!-- design-table:start -->", "<!-- design-table:end -->"


def answers(range_N: float, body: str, pool) -> dict:
    p = DesignProblem(range_N, body=body)
    try:
        nominal = optimise(p, pool, name=f"{body}-{range_N:g}N")
    except DesignError as exc:
        return {"error": str(exc)}
    off = {}
    if _stroke(nominal.design)["near_toggle"]:
        off = {"off_toggle": _nominal(optimise(DesignProblem(range_N, off_toggle=True), pool,
                                               name=f"{body}-{range_N:g}N-off-toggle"))}
    try:
        rob = robust(p, nominal.design, name=f"{body}-{range_N:g}N-robust", pool=pool)
    except DesignError as exc:   # the robust drawing left the hysteresis law's domain
        return {"nominal": _nominal(nominal), **off, "robust_error": str(exc)}
    return {"nominal": _nominal(nominal), **off,
            "robust": {"met": rob.met, "why": rob.why, "seconds": rob.seconds, "angles": _angles(rob.design),
                       "hinges_mm": list(rob.design.used_thickness_mm), "tolerance": rob.tolerance.to_dict(),
                       **_stroke(rob.design)}}


def _nominal(nominal) -> dict:
    return {"hysteresis": nominal.hysteresis, "seconds": nominal.seconds, "design": nominal.design.name,
            "angles": _angles(nominal.design), "hinges_mm": list(nominal.design.used_thickness_mm),
            "tolerance": tolerance(nominal.design).to_dict(), **_stroke(nominal.design)}


def _stroke(design) -> dict:
    """How k_out and A change over the stroke to 1 mm, and whether that is next to the toggle
    (sensor/mechanics/toggle.py)."""
    from sensor.mechanics.toggle import design_stroke_change

    return design_stroke_change(design, 1.0).to_dict()


def _angles(d) -> str:
    return f"{d.phi1_deg:.2f}" + ("" if d.is_basis else f"/{d.phi2_deg:.2f}")


def _cell(a: dict) -> str:
    t = a["tolerance"]
    return (f"{a['angles']}, {min(a['hinges_mm']):.2f}-{max(a['hinges_mm']):.2f} mm: H {t['hysteresis_fraction_p50']:.4f}, "
            f"range {t['range_N_p5']:.2f}-{t['range_N_p95']:.2f} N, P(stress) {100 * t['p_over_stress']:.0f} %"
            + (f"; next to the toggle (k_out x {a['k_out_stroke_ratio']:.1f} over the stroke)" if a["near_toggle"] else ""))


def table(results: dict) -> str:
    lines = ["| range | body | nominal (`dacm design`) | robust (`dacm design --robust`) |", "|---|---|---|---|"]
    for r in RANGES_N:
        for body in ("proposed", "basis"):
            a = results[f"{body}-{r:g}"]
            if "error" in a:
                lines.append(f"| {r:g} N | {body} | no body: {a['error'].split('; ')[-1]} | |")
                continue
            if "robust_error" in a:
                rob = f"none: {a['robust_error']}"
            else:
                rob = _cell(a["robust"]) + ("" if a["robust"]["met"] else f" (not met: {a['robust']['why']})")
            lines.append(f"| {r:g} N | {body} | {_cell(a['nominal'])} | {rob} |")
            if "off_toggle" in a:
                lines.append(f"| {r:g} N | {body}, off the toggle | {_cell(a['off_toggle'])} (`dacm design "
                             "--off-toggle`) | |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--workers", type=int, default=0)
    args = ap.parse_args(argv)
    results = {}
    with task_pool(args.workers) as pool:
        for r in RANGES_N:
            for body in ("proposed", "basis"):
                results[f"{body}-{r:g}"] = answers(r, body, pool)
                print(body, r, flush=True)
    (ROOT / "docs" / "design-table.json").write_text(json.dumps(results, indent=1))
    block = (f"{START}\nAs cut by the water-jet (hinges drawn +0.012 mm, SD 0.025 mm; medians and 5-95 % "
             f"ranges of 200 parts; angles phi1/phi2 in deg, drawn hinges), delrin, 1 mm travel; "
             f"regenerated by `python examples/design_table.py`:\n\n{table(results)}\n{END}")
    readme = ROOT / "README.md"
    text = readme.read_text()
    text = re.sub(re.escape(START) + ".*?" + re.escape(END), lambda _: block, text, flags=re.S)
    readme.write_text(text)
    print(table(results))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
