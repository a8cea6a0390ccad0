"""Verdicts against the thesis and markdown tables of the studies (:mod:`.studies`).

Every verdict prints its numeric criterion (DESIGN section 15) and the status of the runs it
rests on: settled, a limit cycle (reported with its frequency and amplitude, a result like
any other) or unsettled.
"""
from __future__ import annotations

import math

from sensor.pneumatic.loop_metrics import SETTLING_RULE, status_text
from sensor.pneumatic.studies import CH5_CONTROLLERS, CH5_HEADINGS, CH5_PRIMARY, ESTIMATOR_HEADINGS, TABLE4, status_of
from sensor.pneumatic.tuning import SETTLING_BAND, TUNING_RULE


def _verdict(claim: str, ok: bool, criterion: str, value: str, cells=()) -> dict:
    """One verdict; ``cells``: (label, run row) pairs it rests on, whose statuses it carries."""
    st = status_of([c for _, c in cells]) if cells else status_of([])
    cycles = [f"{label} {c['limit_cycle_hz']:.3g} Hz, {c['limit_cycle_amplitude_N']:.3g} N"
              for label, c in cells if c.get("limit_cycle")]
    unsettled = [label for label, c in cells if c["status"] == "unsettled"]
    return {"claim": claim, "verdict": "agrees" if ok else "disagrees", "criterion": criterion, "value": value,
            **st, "limit_cycles": cycles, "unsettled_runs": unsettled}


def observer_verdicts(res: dict) -> list[dict]:
    """The thesis' chapter IV claims against the observer study."""
    ex = {e["experiment"]: e for e in res["experiments"]}
    out = []
    for e in res["experiments"]:
        o, s, v = e["observer"], e["open_loop"], e["valve_ports"]
        if e["controller"] != "smc":
            out.append(_verdict(f"{e['figure']}, {e['experiment']}: the observer's error is far below the standard "
                                "model's and the valve pressures'", o <= 0.5 * min(s, v),
                                "observer <= 1/2 of each", f"{o:.3g} vs {s:.3g} / {v:.3g} kPa^2", _exp(e)))
    one, two = ex["pi sine:1Hz"], ex["pi sine:2Hz"]
    out.append(_verdict("Figures 16-17: the standard-model and valve-port errors are larger at 2 Hz than at 1 Hz",
                        two["open_loop"] > one["open_loop"] and two["valve_ports"] > one["valve_ports"],
                        "ordering holds", f"standard {one['open_loop']:.3g} -> {two['open_loop']:.3g}, valve "
                        f"{one['valve_ports']:.3g} -> {two['valve_ports']:.3g} kPa^2", _exp(one) + _exp(two)))
    smc = [e for e in res["experiments"] if e["controller"] == "smc"]
    gains = []
    for e in smc:
        o, s = e["observer"], e["open_loop"]
        out.append(_verdict(f"Figure 26, {e['reference']}: the observer lowers the pressure error against open loop",
                            o < s, "ordering holds", f"{o:.3g} vs {s:.3g} kPa^2 ({100 * (o / s - 1):+.0f} %)",
                            _exp(e)))
        fo, fs = e["force_mse_N2"]["observer"], e["force_mse_N2"]["open_loop"]
        gains.append(100 * (1 - fo / fs))
    last = smc[-1]
    out.append(_verdict("Figure 26: the observer lowers the force MSE by about 25 % at 1.5 Hz", 12.5 <= gains[-1] <= 50,
                        "within a factor 2 (12.5-50 %)", f"{gains[-1]:+.0f} % ({last['force_mse_N2']['observer']:.3g} "
                        f"vs {last['force_mse_N2']['open_loop']:.3g} N^2)", _exp(last)))
    out.append(_verdict("Figure 26: the observer's force gain grows with frequency", gains[-1] > gains[0],
                        "same trend sign (1.5 Hz gain > 0.5 Hz gain)",
                        ", ".join(f"{e['reference']} {g:+.0f} %" for e, g in zip(smc, gains)),
                        [c for e in smc for c in _exp(e)]))
    sw = res["switch_on"]
    b, a = sw["before"]["pressure_mse_kPa2"], sw["after"]["pressure_mse_kPa2"]
    out.append(_verdict("Figure 27: switching the observer on lowers the pressure error", a <= 0.5 * b,
                        "after <= 1/2 of before", f"{b:.3g} -> {a:.3g} kPa^2 per cycle",
                        [("before the switch-on", sw["status_before"]), ("after it", sw["status_after"])]))
    return out


def _exp(e: dict) -> list[tuple[str, dict]]:
    """An observer-study experiment's runs as verdict cells."""
    return [(f"{e['experiment']} ({k})", c) for k, c in e["status_by_estimator"].items()]


def controller_verdicts(res: dict, key: str = "line_model_thesis", smc_key: str = "smc") -> list[dict]:
    """The thesis' chapter V claims against the controller study, for the line-model row ``key``
    against the SMC row ``smc_key`` (the thesis' controllers tuned by its rule by default)."""
    get = {(r["line_length_m"], r["reference"]): r for r in res["rows"]}
    sines = [r for r in ("sine:0.5Hz", "sine:1Hz", "sine:2Hz") if any(k[1] == r for k in get)]
    long_ = [L for L in (5.0, 7.25, 10.0) if any(k[0] == L for k in get)]
    name = CH5_HEADINGS[key]
    ratio = {(L, r): get[(L, r)][key]["mse1_N2"] / get[(L, r)][smc_key]["mse1_N2"] for L in long_ for r in sines}
    red = {c: 100 * (1 - x) for c, x in ratio.items()}
    def settled(cells):
        return [(f"{CH5_HEADINGS[k]} {c[0]:g} m {c[1]}", get[c][k]) for c in cells for k in (key, smc_key)]
    out = []
    for L in long_:
        cells = [(L, r) for r in sines]
        out.append(_verdict(f"{name} has a lower MSE_1 than SMC at {L:g} m", all(ratio[c] < 1 for c in cells),
                            "ordering holds at every frequency (MSE_1 ratio line model / SMC < 1)",
                            ", ".join(f"{r} {ratio[(L, r)]:.3g}" for r in sines), settled(cells)))
    best = max(red.values()) if red else math.nan
    out.append(_verdict(f"{name}: up to 75 % less force error than SMC for 5-10 m, 0.5-2 Hz", 65 <= best <= 85,
                        "largest reduction 65-85 %", f"{best:.0f} %" if best > -100 else
                        f"none: line model / SMC >= {min(ratio.values()):.3g}", settled(list(red))))
    trend = [0 < red[(L, sines[0])] < red[(L, sines[-1])] or (red[(L, sines[0])] <= 0 < red[(L, sines[-1])])
             for L in long_]
    out.append(_verdict(f"{name}: its advantage over SMC grows with the reference frequency (5-10 m)", all(trend),
                        f"same trend sign: reduction at {sines[-1]} positive and above {sines[0]}'s, every length",
                        "; ".join(f"{L:g} m ratio " + " -> ".join(f"{ratio[(L, r)]:.3g}" for r in sines) for L in long_),
                        settled(list(red))))
    if any(k[0] == 2.0 for k in get):
        cells = [(2.0, r) for r in sines]
        out.append(_verdict("SMC is better than the line model at 2 m",
                            all(get[c][smc_key]["mse1_N2"] < get[c][key]["mse1_N2"] for c in cells), "ordering holds",
                            ", ".join(f"{c[1]} {get[c][smc_key]['mse1_N2']:.3g} vs {get[c][key]['mse1_N2']:.3g} N^2"
                                      for c in cells), settled(cells)))
    spread_t4 = max(max(v[1] for v in (TABLE4[L][r] for L in TABLE4)) / min(v[1] for v in (TABLE4[L][r] for L in TABLE4))
                    for r in sines)
    for r in sines:
        cells = [c for c in get if c[1] == r]
        m2 = [get[c][key]["mse2_N2"] for c in cells]
        sp = max(m2) / min(m2)
        out.append(_verdict(f"{name}: MSE_2 stays almost fixed across lengths at {r}", sp <= spread_t4,
                            f"max/min <= {spread_t4:.2f} (Table 4's own largest spread)",
                            f"{min(m2):.3g}-{max(m2):.3g} N^2 ({sp:.2f}x)", settled(cells)))
    cells = [c for c in get if get[c]["thesis_table4"]]
    ratio = [get[c][key]["mse1_N2"] / get[c]["thesis_table4"]["mse1_N2"] for c in cells]
    inside = sum(0.5 <= x <= 2 for x in ratio)
    out.append(_verdict(f"{name}: MSE_1 as in Table 4", inside == len(cells), "within a factor 2 in every cell",
                        f"{inside} of {len(cells)} cells; ratio to Table 4 {min(ratio):.2g}-{max(ratio):.2g}",
                        settled(cells)))
    cells = [c for c in get if c[1] == "sine:2Hz"]
    pe = [(get[c][key]["line_model_pressure_mse_kPa2"], get[c][key]["pressure_mse_kPa2"]) for c in cells]
    out.append(_verdict("Figure 37: at 2 Hz the line model estimates the chamber pressures far better than the "
                        "standard model", all(a <= 0.5 * b for a, b in pe), "line model <= 1/2 of standard",
                        ", ".join(f"{c[0]:g} m {a:.3g} vs {b:.3g} kPa^2" for c, (a, b) in zip(cells, pe)),
                        settled(cells)))
    return out


def verdict_lines(verdicts: list[dict]) -> list[str]:
    """Markdown bullets: verdict, criterion, claim, value, and the runs' status when not settled."""
    out = []
    for v in verdicts:
        note = ""
        if v["limit_cycles"]:
            note += " [limit cycles: " + "; ".join(v["limit_cycles"]) + "]"
        if v["unsettled_runs"]:
            note += " [unsettled: " + "; ".join(v["unsettled_runs"]) + "]"
        out.append(f"- {v['verdict']} ({v['criterion']}): {v['claim']}: {v['value']}{note}")
    return out


# --- tables (markdown, next to the thesis) -----------------------------------------------------------

def _fmt(x: float) -> str:
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else (f"{x:.3g}" if abs(x) < 1e4 else f"{x:.3e}")


def _cells_status(row: dict, keys) -> str:
    """'settled', or each run that is not, with its status."""
    notes = [f"{CH5_HEADINGS[k]}: {status_text(row[k])}" for k in keys
             if not row[k]["settled"] or row[k].get("settled_by") == "noise_free_twin"]
    return "; ".join(notes) if notes else "settled"


def observer_tables(res: dict) -> str:
    h = ESTIMATOR_HEADINGS
    lines = ["### Chapter IV: pressure estimation, 7.25 m lines (eq 44 MSE, kPa^2; force MSE N^2)", "",
             f"| experiment | figure | {h['observer']} | {h['open_loop']} | {h['valve_ports']} | force MSE "
             f"{h['observer']} / open loop / valve ports | status |", "|---|---|---|---|---|---|---|"]
    for e in res["experiments"]:
        f = e["force_mse_N2"]
        st = "; ".join(f"{k}: {status_text(c)}" for k, c in e["status_by_estimator"].items() if not c["settled"])
        lines.append(f"| {e['experiment']} | {e['figure']} | {_fmt(e['observer'])} | {_fmt(e['open_loop'])} | "
                     f"{_fmt(e['valve_ports'])} | {_fmt(f['observer'])} / {_fmt(f['open_loop'])} / "
                     f"{_fmt(f['valve_ports'])} | {st or 'settled'} |")
    sw = res["switch_on"]
    lines += ["", f"Switch-on (Figure 27, SMC impedance 0.5 Hz, observer on at {sw['on_s']:g} s): pressure MSE per "
              f"cycle {_fmt(sw['before']['pressure_mse_kPa2'])} -> {_fmt(sw['after']['pressure_mse_kPa2'])} kPa^2, "
              f"force MSE {_fmt(sw['before']['force_mse_N2'])} -> {_fmt(sw['after']['force_mse_N2'])} N^2 "
              f"({sw['note']}); before the switch-on {status_text(sw['status_before'])}, after it "
              f"{status_text(sw['status_after'])}.", "", f"Status rule: {SETTLING_RULE}.", "", "Against the thesis:", ""]
    lines += verdict_lines(observer_verdicts(res))
    return "\n".join(lines) + "\n"


def _gain_text(g: dict) -> str:
    if "eta_N_s" in g:
        return f"eta {g['eta_N_s']:.4g} N/s, phi {g['phi_N']:.3g} N, lambda {g['lam_per_s']:.3g} /s"
    return (f"k_p1 {g['kp1']:.3g}, k_i1 {g['ki1_per_s']:.3g} /s, lambda {g['lam_per_s']:.3g} /s, "
            f"k_p2 {g['kp2_per_s']:.3g} /s, "
            f"k_i2 {g['ki2_per_s2']:.4g} /s^2, k_m {g['flow_rate_per_s']:.3g} /s")


def _step_text(c: dict) -> str:
    ts = (f"not settled (last second's error RMS {c['tail_rms_N']:.3g} N, band {100 * SETTLING_BAND:g} %)"
          if c["settling_time_s"] is None else f"{c['settling_time_s']:.3g} s")
    return f"t_s(2 %) {ts}, overshoot {100 * c['overshoot']:.1f} % (zeta {c['damping_ratio']:.2f})"


def tuning_table(tuning: dict) -> list[str]:
    """The tuned gains per length with both step responses' metrics beside them."""
    lines = [f"Gains by the thesis' tuning rule ({TUNING_RULE}):", "",
             "| length | SMC gains | SMC step | line model gains | line model step | matched |", "|---|---|---|---|---|---|"]
    for length, t in tuning.items():
        lines.append(f"| {float(length):g} m | {_gain_text(t['smc']['gains'])} | {_step_text(t['smc'])} | "
                     f"{_gain_text(t['line_model']['gains'])} | {_step_text(t['line_model'])} | "
                     + (f"yes (mismatch {t['mismatch']:.2f})" if t["matched"] else
                        "**no**: no line-model candidate settles (SMC at its rule, line model at its least oscillation)")
                     + " |")
    return lines


def _mse_table(rows: list[dict], keys) -> list[str]:
    lines = ["| length | reference | " + " | ".join(f"MSE_1 {CH5_HEADINGS[k]}" for k in keys)
             + " | MSE_2 " + " / ".join(CH5_HEADINGS[k] for k in keys if k.startswith("line"))
             + " | Table 4 MSE_1 / MSE_2 | status |", "|---" * (len(keys) + 5) + "|"]
    for r in rows:
        t4 = r["thesis_table4"]
        lines.append(f"| {r['line_length_m']:g} m | {r['reference']} | "
                     + " | ".join(_fmt(r[k]["mse1_N2"]) for k in keys)
                     + " | " + " / ".join(_fmt(r[k]["mse2_N2"]) for k in keys if k.startswith("line")) + " | "
                     + (f"{t4['mse1_N2']:g} / {t4['mse2_N2']:g}" if t4 else "-") + f" | {_cells_status(r, keys)} |")
    return lines


def controller_tables(res: dict) -> str:
    rows = res["rows"]
    alt = [k for k in CH5_CONTROLLERS if k not in CH5_PRIMARY]
    lines = ["### Chapter V: line-model controller vs standard SMC (Table 4, Figure 32), N^2", "",
             "Primary rows: the thesis' controllers with the gains of its tuning rule.", ""]
    lines += _mse_table(rows, CH5_PRIMARY)
    lines += [""] + tuning_table(res["tuning"])
    lines += ["", "Alternatives: the fixed gain rules (smc_gains, line_model_gains) and our line-flow damping "
              "k_m = 2 w_L:", ""]
    lines += _mse_table(rows, alt)
    lines += ["", "### Chapter V: chamber-pressure estimation from the valve pressures (Figure 37), kPa^2", "",
              "| length | reference | standard model | line model (thesis controller's run) | line model (ours) |",
              "|---|---|---|---|---|"]
    for r in rows:
        if r["reference"] == "sine:2Hz":
            lines.append(f"| {r['line_length_m']:g} m | {r['reference']} | {_fmt(r['line_model_thesis']['pressure_mse_kPa2'])} | "
                         f"{_fmt(r['line_model_thesis']['line_model_pressure_mse_kPa2'])} | "
                         f"{_fmt(r['line_model_damped']['line_model_pressure_mse_kPa2'])} |")
    lines += ["", f"Status rule: {SETTLING_RULE}.", "", "Against the thesis, its controllers tuned by its rule (primary):",
              ""]
    lines += verdict_lines(controller_verdicts(res, "line_model_thesis", "smc"))
    lines += ["", "The same claims with the fixed gain rules:", ""]
    lines += verdict_lines(controller_verdicts(res, "line_model_thesis_rule", "smc_rule"))
    lines += ["", "The same claims for our extension (line-flow damping k_m = 2 w_L, against SMC by the rule):", ""]
    lines += verdict_lines(controller_verdicts(res, "line_model_damped", "smc_rule"))
    return "\n".join(lines) + "\n"


def plant_physics_tables(res: dict) -> str:
    """How each plant-physics variant moves the primary rows' MSE_1 and the verdicts."""
    base = res["rows"]["baseline"]
    names = [k for k in res["variants"] if k != "baseline"]
    lines = ["### Chapter V with the rig's friction, spool and thermodynamics (primary rows, one at a time), N^2", "",
             "Variants: " + "; ".join(f"{k}: {res['variants'][k]}" for k in names)
             + ". Gains tuned on the baseline plant and held.", "",
             "| length | reference | controller | baseline | " + " | ".join(names) + " | status |",
             "|---" * (len(names) + 5) + "|"]
    for i, r in enumerate(base):
        for key in CH5_PRIMARY:
            cells = [res["rows"][n][i][key] for n in names]
            st = "; ".join(f"{n}: {status_text(c)}" for n, c in zip(["baseline", *names], [r[key], *cells])
                           if not c["settled"])
            lines.append(f"| {r['line_length_m']:g} m | {r['reference']} | {CH5_HEADINGS[key]} | "
                         f"{_fmt(r[key]['mse1_N2'])} | "
                         + " | ".join(f"{_fmt(c['mse1_N2'])} ({c['mse1_N2'] / r[key]['mse1_N2']:.2f}x)" for c in cells)
                         + f" | {st or 'settled'} |")
    before = controller_verdicts({"rows": base})
    lines += ["", "Verdicts (primary rows) on the baseline plant and how each variant moves them:", ""]
    for j, v in enumerate(before):
        moved = []
        for n in names:
            w = controller_verdicts({"rows": res["rows"][n]})[j]
            change = "same" if w["verdict"] == v["verdict"] else f"**{w['verdict']}**"
            moved.append(f"{n}: {change} ({w['value']}{'' if w['settled'] else ', ' + w['status']})")
        lines.append(f"- {v['claim']} ({v['criterion']}): baseline {v['verdict']} ({v['value']}); " + "; ".join(moved))
    return "\n".join(lines) + "\n"


def sensor_tables(res: dict) -> str:
    lines = ["### The DACM sensor in the loop (PI force control, observer on, 7.25 m, 1 Hz)", "",
             "| sensor | range (N) | hysteresis (% FS) | resolution (N) | stiffness (N/mm) | loop spring (N/mm) | "
             "reading | reading RMS error (N) | force MSE (N^2) | pressure MSE (kPa^2) | status |", "|---" * 11 + "|"]
    for r in res["rows"]:
        lines.append(f"| {r['sensor']} | {r['range_N']:.3g} | {r['hysteresis_pct']:.3g} | {r['resolution_N']:.2g} | "
                     f"{r['stiffness_N_mm']:.3g} | {r['loop_stiffness_N_mm']:.3g} | {r['reading']} | "
                     f"{r['reading_rms_error_N']:.3g} | {_fmt(r['force_mse_N2'])} | {_fmt(r['pressure_mse_kPa2'])} | "
                     f"{status_text(r)} |")
    return "\n".join(lines) + "\n"
