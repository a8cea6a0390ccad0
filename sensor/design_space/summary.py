"""The summary a sweep prints: cells per hinge set and the equal-range answer at each range
of ``SUMMARY_RANGES_N`` (DESIGN section 13), as a JSON-ready dict and as text."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

from geometry.params import cut_note
from sensor.design_space.equal_range import SAME_RANGE, SUMMARY_RANGES_N, admissible, answer_at


def summary(ds, n_new, t_solve_s, t_total_s, written) -> dict:
    """The numbers the sweep prints: cells per hinge set and the equal-range answer at
    each range of ``SUMMARY_RANGES_N`` (NaN-free: a missing body is None)."""
    kerf = json.loads(ds.attrs["design"]).get("kerf_mm") if "design" in ds.attrs else None
    out = {"cells": int(ds["computed"].size), "computed_now": n_new, "kerf_mm": kerf, "solve_s": t_solve_s,
           "total_s": t_total_s, "hinge_sets": {}, "equal_range": [], "files": [str(p) for p in written]}
    for h in ds["hinges"].values:
        feas, ok = ds["feasible"].sel(hinges=h).values, admissible(ds, str(h))
        out["hinge_sets"][str(h)] = {"cells": int(feas.size), "feasible_cells": int(feas.sum()),
                                     "admissible_cells": int(ok.sum())}
    for r in SUMMARY_RANGES_N:
        for h in ds["hinges"].values:
            out["equal_range"].append(_with_ratios(_plain(asdict(answer_at(ds, str(h), r)))))
    return out


def _with_ratios(a: dict) -> dict:
    """An answer with the ratios the summary prints, unrounded: the cell's H over the best
    basis body's of the range (``hysteresis_ratio``; over the best regardless of stress when
    none is within it, ``hysteresis_ratio_any_stress``), 1 / A (``inverse_amplification``)
    and the resolution ratio; None where a body is missing."""
    c, b, loose = a["cell"], a["basis"], a["basis_any_stress"]

    def ratio(x, y):
        return None if x is None or y is None else x / y

    a["hysteresis_ratio"] = ratio(c and c["hysteresis"], b["hysteresis"])
    a["hysteresis_ratio_any_stress"] = ratio(c and c["hysteresis"], loose["hysteresis"])
    a["inverse_amplification"] = ratio(1.0, c and c["amplification"])
    a["resolution_ratio"] = ratio(c and c["resolution_N"], b["resolution_N"])
    return a


def _plain(x):
    """JSON-ready: numpy scalars to Python numbers (integers stay integers), NaN to None."""
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, str) or x is None:
        return x
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    v = float(x)
    return None if v != v else v


def summary_text(s: dict) -> str:
    lines = [f"swept {s['cells']} cells ({s['computed_now']} computed now) in {s['solve_s']:.1f} s; "
             f"total {s['total_s']:.1f} s; " + cut_note(s["kerf_mm"])]
    for h, e in s["hinge_sets"].items():
        lines.append(f"hinge set {h}: {e['feasible_cells']} of {e['cells']} cells feasible, "
                     f"{e['admissible_cells']} of them within the allowable hinge stress at full scale")
    lines.append(f"equal range: the DACM cell with the lowest H within {100 * SAME_RANGE:g} % of each range, "
                 "against the basis body of that range with the lowest H (any phi1, hinges 1-8 of any thickness)")
    lines += ["  " + _answer_line(a) for a in s["equal_range"]]
    files = s["files"]
    lines.append(f"wrote {', '.join(Path(f).name for f in files)} in {Path(files[0]).parent}")
    return "\n".join(lines)


def _answer_line(a: dict) -> str:
    """One line of the equal-range summary."""
    head = f"{a['range_N']:>4g} N, {a['hinges']}: "
    if a["cell"] is None:
        return head + "no cell within the allowable stress reaches this range"
    c, b = a["cell"], a["basis"]
    text = (head + f"DACM phi1 = {c['phi1_deg']:.2f}, phi2 = {c['phi2_deg']:.2f} deg, range {c['range_N']:.3g} N, "
            f"A = {c['amplification']:.2f}, H = {c['hysteresis']:.4f}, resolution {1e3 * c['resolution_N']:.3f} mN; ")
    if b["hysteresis"] is not None:
        text += (f"basis phi1 = {b['phi1_deg']:.1f} deg, hinges {b['hinge_mm']:.3f} mm: H = {b['hysteresis']:.4f}, "
                 f"resolution {1e3 * b['resolution_N']:.3f} mN; H ratio {a['hysteresis_ratio']:.3f} "
                 f"(1/A = {a['inverse_amplification']:.3f}), "
                 f"resolution ratio {a['resolution_ratio']:.3f}")
    else:
        loose = a["basis_any_stress"]
        text += "no basis body reaches it within the allowable stress" + (
            f" (best beyond it: H = {loose['hysteresis']:.4f} at {loose['stress_utilisation']:.2f} x the "
            f"allowable stress; H ratio {a['hysteresis_ratio_any_stress']:.3f})"
            if loose["hysteresis"] is not None else "")
    from sensor.mechanics.toggle import StrokeChange

    toggle = StrokeChange.from_dict(a["toggle"], c["phi2_deg"])
    return text + (f" [{toggle.warning()}]" if toggle.near_toggle else "") + (f" [edge: {a['edge']}]" if a["edge"] else "")
