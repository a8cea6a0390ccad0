"""The experiment grids of thesis chapters IV and V on the high-fidelity plant, and the DACM
sensor in the loop: :func:`observer_study` (Figures 16-19, 26-27), :func:`controller_study`
(Table 4, Figures 32-37, gains by the thesis' tuning rule, :mod:`.tuning`),
:func:`plant_physics_study` (chapter V's primary rows with the friction, spool dynamics and
energy equation the thesis' rig has) and :func:`sensor_study`.  Each returns rows (dicts) next
to the thesis' numbers; :mod:`.verdicts` turns them into tables and verdicts.  Every run is
measured by :func:`~sensor.pneumatic.loop_metrics.metrics` and named settled, limit_cycle or
unsettled there.
"""
from __future__ import annotations

import json
import warnings
from dataclasses import replace

import numpy as np
import xarray as xr

from sensor.errors import CapacityWarning
from sensor.pneumatic.controllers import Impedance
from sensor.pneumatic.cylinder import spring_contact
from sensor.pneumatic.dacm_sensor import DacmForceSensor, sensor_reference, series_spring
from sensor.pneumatic.experiment import (
    ENERGY_WALL_W_K,
    STUDY_DURATION_S,
    STUDY_SPOOL_BANDWIDTH_HZ,
    THESIS_STICTION_N,
    Setup,
    build_plant,
    measure,
    run,
    settling_duration_s,
)
from sensor.pneumatic.loop_metrics import classify, per_cycle, window
from sensor.pneumatic.observer import ObserverModel, PressureObserver
from sensor.pneumatic.tuning import tune

ESTIMATORS = {"force": "observer", "standard": "open_loop", "valve": "valve_ports"}   # kind -> JSON key
ESTIMATOR_HEADINGS = {"observer": "observer", "open_loop": "open loop (standard model)",
                      "valve_ports": "valve ports"}
#: Plant substep of the observer study's SMC runs (s): the valve-port baseline under SMC converges
#: slowly with the substep (the switching law's fast content at the port; 0.5 Hz: 2.24 kPa^2 at
#: 0.1 ms, 1.73 at 20 us, 1.66 at 10 us, measured), so these runs take 20 us, within 5 % of 10 us.
SMC_SUBSTEP_S = 2.0e-5
ROW_KEYS = ("status", "settled", "limit_cycle", "limit_cycle_hz", "limit_cycle_amplitude_N", "settled_by",
            "noise_block_change")


def _row(setup: Setup, **extra) -> tuple[dict, xr.Dataset]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", CapacityWarning)
        ds = run(setup)
    out = {**extra, **measure(setup, ds), "gains": json.loads(ds.attrs["gains"]),
           "warnings": [str(w.message) for w in caught]}
    return out, ds


def _run_plan(plan: list[tuple[object, Setup]], progress, keep=lambda key: True) -> dict:
    """Run every (key, setup) of ``plan``: {key: (row, dataset or None)}, the dataset kept only
    where ``keep(key)`` (a 50 s run of the 20-segment plant is ~0.3 GB; a grid cannot hold them
    all); ``progress(done, total, label)`` after each."""
    done = {}
    for i, (key, setup) in enumerate(plan):
        row, ds = _row(setup)
        done[key] = (row, ds if keep(key) else None)
        if progress is not None:
            progress(i + 1, len(plan), f"{setup.controller} {setup.reference} {setup.line_length_m:g} m")
    return done


def status_of(rows: list[dict]) -> dict:
    """The joint status of several runs: unsettled if one is, else limit_cycle if one is, else
    settled; with the booleans ``settled`` and ``limit_cycle``."""
    st = [r["status"] for r in rows]
    status = "unsettled" if "unsettled" in st else ("limit_cycle" if "limit_cycle" in st else "settled")
    return {"status": status, "settled": status == "settled", "limit_cycle": status == "limit_cycle"}


OBSERVER_EXPERIMENTS = (("pi", "sine:1Hz", "Figure 16"), ("pi", "sine:2Hz", "Figure 17"),
                        ("impedance", "square:0.5Hz", "Figure 18"), ("smc", "sine:0.5Hz", "Figure 26"),
                        ("smc", "sine:1Hz", "Figure 26"), ("smc", "sine:1.5Hz", "Figure 26"))


def _observer_setup(ctrl: str, ref: str, kind: str, duration_s: float | None, segments: int, **kw) -> Setup:
    duration_s = settling_duration_s(ref) if duration_s is None else duration_s
    if ctrl != "smc":
        return Setup(controller=ctrl, observer=kind, reference=ref, duration_s=duration_s, segments=segments, **kw)
    s = Setup(controller="smc", observer=kind, reference=ref, duration_s=duration_s, segments=segments,
              valve="enfield-lh05", substep_s=SMC_SUBSTEP_S, **kw)
    return replace(s, gains=(("impedance", _impedance_for(s)),))


def observer_study(duration_s: float | None = None, segments: int = 20, progress=None) -> dict:
    """Chapter IV, 7.25 m lines: eq 44 pressure-estimation MSE (kPa^2) of the observer, the
    open-loop standard model and the valve-port pressures, and the force MSE of each run, at 1
    and 2 Hz PI force tracking and square-wave impedance control (Festo valve, Figures 16-18)
    and SMC impedance control with z_d a 0.5, 1 or 1.5 Hz sine (Enfield valve, Figure 26); and
    the switch-on of Figure 27 (0.5 Hz, observer on after ``duration_s``, run twice as long).
    ``duration_s``: every run's length (default :func:`settling_duration_s` of its reference).

    Returns ``experiments`` (one dict per experiment with the keys ``observer``, ``open_loop``,
    ``valve_ports`` in kPa^2, ``force_mse_N2`` per estimator, ``settled``), ``switch_on``,
    ``runs`` (datasets by (controller, reference, estimator key))."""
    plan = [((c, r, key), _observer_setup(c, r, kind, duration_s, segments))
            for c, r, _ in OBSERVER_EXPERIMENTS for kind, key in ESTIMATORS.items()]
    on_s = settling_duration_s("sine:0.5Hz") if duration_s is None else duration_s
    plan.append(("switch_on", _observer_setup("smc", "sine:0.5Hz", "force", 2 * on_s, segments,
                                              observer_on_s=on_s)))
    done = _run_plan(plan, progress)
    experiments = []
    for c, r, fig in OBSERVER_EXPERIMENTS:
        rows = {key: done[(c, r, key)][0] for key in ESTIMATORS.values()}
        experiments.append({"experiment": f"{c} {r}" if c != "smc" else f"smc impedance z_d {r}", "figure": fig,
                            "controller": c, "reference": r,
                            **{key: rows[key]["pressure_mse_kPa2"] for key in rows},
                            "force_mse_N2": {key: rows[key]["force_mse_N2"] for key in rows},
                            **status_of(list(rows.values())),
                            "status_by_estimator": {key: {k: rows[key][k] for k in ROW_KEYS if k in rows[key]}
                                                    for key in rows},
                            "window_s": rows["observer"]["window_s"],
                            "warnings": sorted({w for key in rows for w in rows[key]["warnings"]})})
    sw_ds = done["switch_on"][1]
    sw_ref = _observer_setup("smc", "sine:0.5Hz", "force", 2 * on_s, segments).ref
    sw = per_cycle(sw_ds, 0.5)
    before = [i for i, c in enumerate(sw["cycle_start_s"]) if on_s - 3 * 2.0 <= c < on_s]
    after = list(range(len(sw["cycle_start_s"])))[-3:]
    switch_on = {"on_s": on_s, "cycle_start_s": sw["cycle_start_s"], "force_mse_N2": sw["force_mse_N2"],
                 "pressure_mse_kPa2": sw["pressure_mse_kPa2"],
                 "before": {k: float(np.mean([sw[k][i] for i in before])) for k in ("force_mse_N2", "pressure_mse_kPa2")},
                 "after": {k: float(np.mean([sw[k][i] for i in after])) for k in ("force_mse_N2", "pressure_mse_kPa2")},
                 "note": "means over the 3 cycles before the switch-on and the last 3 cycles",
                 "status_before": _strip(classify(sw_ds.sel(time=slice(0.0, on_s)), sw_ref)),
                 "status_after": _strip(classify(sw_ds, sw_ref))}
    runs = {k: v[1] for k, v in done.items()}
    return {"experiments": experiments, "switch_on": switch_on, "runs": runs}


def _strip(status: dict) -> dict:
    return {k: v for k, v in status.items() if k != "evidence"}


def _impedance_for(setup: Setup) -> Impedance:
    plant = build_plant(setup)
    model = ObserverModel.from_plant(plant)
    return Impedance(model, setup.ref, PressureObserver(model, "valve"), 1e-3)


CH5_LENGTHS_M = (2.0, 5.0, 7.25, 10.0)
CH5_REFERENCES = ("step", "sine:0.5Hz", "sine:1Hz", "sine:2Hz")
# row key -> (controller, gains): the thesis' controllers tuned by its rule (section 5.4.2,
# :mod:`.tuning`) are the primary rows; the fixed gain rules and the project's line-flow damping
# are named alternatives
CH5_CONTROLLERS = {"smc": ("smc", "tuned"), "line_model_thesis": ("line-model", "tuned"),
                   "smc_rule": ("smc", "rule"), "line_model_thesis_rule": ("line-model", "rule"),
                   "line_model_damped": ("line-model-damped", "rule")}
CH5_PRIMARY = ("smc", "line_model_thesis")
CH5_HEADINGS = {"smc": "SMC (tuned)", "line_model_thesis": "line model (thesis, tuned)",
                "smc_rule": "SMC (rule)", "line_model_thesis_rule": "line model (thesis, rule)",
                "line_model_damped": "line model + k_m (ours, rule)"}
# Table 4 (line-model controller): length -> {reference: (MSE_1, MSE_2)} in N^2
TABLE4 = {2.0: {"sine:0.5Hz": (6.38, 4.33), "sine:1Hz": (9.28, 5.68), "sine:2Hz": (17.63, 8.16)},
          5.0: {"sine:0.5Hz": (1.23, 3.66), "sine:1Hz": (2.63, 5.89), "sine:2Hz": (6.44, 8.22)},
          7.25: {"sine:0.5Hz": (1.6, 4.0), "sine:1Hz": (3.36, 5.52), "sine:2Hz": (12.83, 7.97)},
          10.0: {"sine:0.5Hz": (2.44, 6.33), "sine:1Hz": (7.08, 8.85), "sine:2Hz": (22.85, 10.37)}}


def tunings(lengths=CH5_LENGTHS_M, segments: int = 20, amplitude_N: float = 24.0, progress=None) -> dict:
    """The thesis' tuning (:func:`~sensor.pneumatic.tuning.tune`) at each length."""
    out = {}
    for i, length in enumerate(lengths):
        out[length] = tune(length, segments, amplitude_N)
        if progress is not None:
            progress(i + 1, len(lengths), f"tuning {length:g} m")
    return out


def _ch5_setup(length: float, ref: str, key: str, tuned: dict, duration_s, amplitude_N: float, segments: int,
               **plant) -> Setup:
    ctrl, gains = CH5_CONTROLLERS[key]
    s = Setup(controller=ctrl, observer="standard", reference=ref, amplitude_N=amplitude_N, line_length_m=length,
              valve="enfield-lh05", duration_s=settling_duration_s(ref) if duration_s is None else duration_s,
              segments=segments, **plant)
    if gains == "tuned":
        s = replace(s, gains=tuple(tuned[length]["smc" if ctrl == "smc" else "line_model"]["gains"].items()))
    return s


def _ch5_cell(r: dict) -> dict:
    return {"mse1_N2": r["force_mse_N2"], "mse2_N2": r.get("virtual_input_mse_N2"),
            "pressure_mse_kPa2": r["pressure_mse_kPa2"],
            "line_model_pressure_mse_kPa2": r.get("line_model_pressure_mse_kPa2"),
            **{k: r[k] for k in ROW_KEYS if k in r}, "window_s": r["window_s"], "gains": r["gains"],
            "warnings": r["warnings"]}


def _ch5_rows(done: dict, lengths, references, keys) -> list[dict]:
    rows = []
    for length in lengths:
        for ref in references:
            row = {"line_length_m": length, "reference": ref}
            for key in keys:
                row[key] = _ch5_cell(done[(length, ref, key)][0])
            th = TABLE4.get(length, {}).get(ref)
            row["thesis_table4"] = {"mse1_N2": th[0], "mse2_N2": th[1]} if th else None
            row.update(status_of([row[key] for key in keys]))
            rows.append(row)
    return rows


def controller_study(duration_s: float | None = None, amplitude_N: float = 24.0, segments: int = 20,
                     lengths=CH5_LENGTHS_M, references=CH5_REFERENCES, keep_runs=(), progress=None,
                     tuned: dict | None = None) -> dict:
    """Chapter V on 2, 5, 7.25 and 10 m lines with step, 0.5, 1 and 2 Hz references, Enfield valve,
    standard-model pressures for SMC.  Primary rows: SMC and the thesis' line-model controller with
    the gains of the thesis' tuning rule at each length (``tuned``: :func:`tunings`, computed when
    not given); alternatives: both with the fixed gain rules, and ours with k_m.  The same gains
    for every reference; ``duration_s`` every run's length (default :func:`settling_duration_s`).
    One row per (length, reference) with a cell per :data:`CH5_CONTROLLERS` key (``mse1_N2``,
    ``mse2_N2``, pressure MSEs, ``status``, ``settled``, ``limit_cycle`` with its frequency and
    amplitude, gains), ``thesis_table4`` and the joint status; ``tuning`` per length; ``runs``
    keeps the datasets named in ``keep_runs`` ((length, reference, row key))."""
    tuned = tunings(lengths, segments, amplitude_N, progress) if tuned is None else tuned
    plan = [((length, ref, key), _ch5_setup(length, ref, key, tuned, duration_s, amplitude_N, segments))
            for length in lengths for ref in references for key in CH5_CONTROLLERS]
    done = _run_plan(plan, progress, keep=set(keep_runs).__contains__)
    runs = {k: v[1] for k, v in done.items() if v[1] is not None}
    return {"rows": _ch5_rows(done, lengths, references, CH5_CONTROLLERS), "tuning": _tuning_summary(tuned),
            "tuned": tuned, "runs": runs}


def _tuning_summary(tuned: dict) -> dict:
    """Per length: the chosen gains and step metrics of both controllers (candidates dropped)."""
    return {length: {k: t[k] for k in ("smc", "line_model", "matched", "mismatch")} for length, t in tuned.items()}


#: The plant-physics variants, one at a time: Setup fields and a label
PLANT_PHYSICS = {"stiction": ({"stiction_N": THESIS_STICTION_N}, f"stiction {THESIS_STICTION_N:g} N (thesis 4.3)"),
                 "spool": ({"spool_bandwidth_Hz": STUDY_SPOOL_BANDWIDTH_HZ},
                           f"spool bandwidth {STUDY_SPOOL_BANDWIDTH_HZ:g} Hz (first order, assumed)"),
                 "energy": ({"energy": True}, f"chamber energy equation (wall h A {ENERGY_WALL_W_K:g} W/K)")}


def plant_physics_study(duration_s: float | None = None, amplitude_N: float = 24.0, segments: int = 20,
                        lengths=CH5_LENGTHS_M, references=CH5_REFERENCES, progress=None,
                        tuned: dict | None = None, baseline: dict | None = None) -> dict:
    """Chapter V's primary rows (tuned SMC and thesis line model, gains tuned on the baseline
    plant and held) on the baseline plant and with each of :data:`PLANT_PHYSICS`, one at a time.
    ``tuned`` and ``baseline`` (a :func:`controller_study` result on the same grid, whose primary
    rows are the baseline) save their runs.  Returns ``variants`` (key -> label), ``rows`` per
    variant (the controller study's row form, ``baseline`` included) and ``tuning``."""
    if baseline is not None:
        tuned = baseline["tuned"]
    tuned = tunings(lengths, segments, amplitude_N, progress) if tuned is None else tuned
    variants = {"baseline": ({}, "baseline plant"), **PLANT_PHYSICS}
    plan = [((name, length, ref, key), _ch5_setup(length, ref, key, tuned, duration_s, amplitude_N, segments,
                                                   **fields))
            for name, (fields, _) in variants.items() for length in lengths for ref in references
            for key in CH5_PRIMARY if not (baseline is not None and name == "baseline")]
    done = _run_plan(plan, progress, keep=lambda key: False)
    rows = {name: _ch5_rows({k[1:]: v for k, v in done.items() if k[0] == name}, lengths, references, CH5_PRIMARY)
            for name in variants if not (baseline is not None and name == "baseline")}
    if baseline is not None:
        rows["baseline"] = [{**{k: v for k, v in r.items() if k not in CH5_CONTROLLERS or k in CH5_PRIMARY},
                             **status_of([r[k] for k in CH5_PRIMARY])} for r in baseline["rows"]]
        rows = {"baseline": rows.pop("baseline"), **rows}
    return {"variants": {k: v[1] for k, v in variants.items()}, "rows": rows, "tuning": _tuning_summary(tuned)}


SENSOR_PRESETS = ("basis-as-cut", "sample-a-as-cut", "sample-b-as-cut")


def sensor_study(duration_s: float = STUDY_DURATION_S, environment_N_m: float = 2000.0, segments: int = 20,
                 presets=SENSOR_PRESETS, frequency_Hz: float = 1.0, progress=None) -> dict:
    """The DACM sensor as the loop's force sensor (basis, samples A and B) against an ideal load
    cell on the same loop: PI force control of a 1 Hz sine between 15 % and 85 % of the sensor's
    range, observer on, 7.25 m lines, Festo valve, a push-only 2 kN/m spring in series with the
    sensor body.  Force MSE against the true contact force; pressure MSE of eq 44."""
    plan, info = [], {}
    for name in presets:
        sensor = DacmForceSensor(name)
        k = series_spring(environment_N_m, sensor.stiffness_N_m)
        amp, off = sensor_reference(sensor.range_N)
        for label, fs in (("DACM " + name, sensor), ("load cell (0.02 N noise)", None)):
            s = Setup(controller="pi", observer="force", reference=f"sine:{frequency_Hz:g}Hz", amplitude_N=amp,
                      offset_N=off, duration_s=duration_s, segments=segments, environment=spring_contact(k, 0.025),
                      force_sensor=fs)
            plan.append(((name, label), s))
            info[(name, label)] = dict(sensor=name, reading=label, range_N=sensor.range_N,
                                       hysteresis_pct=sensor.sheet.hysteresis_pct,
                                       resolution_N=sensor.sheet.resolution_N,
                                       stiffness_N_mm=sensor.stiffness_N_m / 1e3, loop_stiffness_N_mm=k / 1e3)
    done = _run_plan(plan, progress)
    rows, runs = [], {}
    for key, s in plan:
        row, ds = done[key]
        w = ds.sel(time=window(ds, s.ref))
        row = {**info[key], **row,
               "reading_rms_error_N": float(((w.measured_force_N - w.environment_force) ** 2).mean() ** 0.5)}
        rows.append(row)
        runs[key] = ds
    return {"rows": rows, "runs": runs}

