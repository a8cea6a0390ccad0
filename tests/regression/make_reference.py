"""Write the reference values that the performance work must keep (within 1e-6 relative).

Run once from the code BEFORE a speed change (this file was first run at main d567a96; re-run
after the model of the part as cut, issue 23, changed every result on purpose, again
when the root rule took the face's lean, when the knee blocks began to bend, when the
members took the axial force's second-order term, when the hinges took the axial spread
into their bodies and the input its contact, and when that second-order term took the
oblique roots' centroid offset):
    python -m tests.regression.make_reference
It writes tests/regression/data/reference.npz: every preset's solve (default options and to
a target force), the datasheet and cross-axis figures of every preset with the `dacm sensor`
defaults, the optics curves of both intensity models, and the dataset of REFERENCE_SWEEP.
"""

import dataclasses
import subprocess
from pathlib import Path

import numpy as np

from geometry.params import PRESETS, preset
from geometry.topology import build_beam_model
from sensor.design_space.dataset import QUALIFIERS
from sensor.design_space.execution import run_sweep
from sensor.design_space.spec import Grid, SweepSpec
from sensor.mechanics.solver import solve
from sensor.readout.datasheet import cross_axis, datasheet
from sensor.readout.optics import (
    MODELS,
    OpticsSetup,
    output_voltage,
    voltage_slope,
    working_range,
)
from sensor.readout.sensor_model import build_sensor

PATH = Path(__file__).with_name("data") / "reference.npz"
#: Solve fields compared (scalars and arrays); residual and increments are not results.
SOLVE_FIELDS = ("amplification", "k_out_N_per_mm", "strain_energy_mJ", "input_force_N",
                "input_travel_mm", "output_travel_mm", "force_N", "input_mm", "output_mm",
                "work_mJ", "member_forces", "member_strain_energy_mJ", "deformed_nodes",
                "node_rotation_rad")
#: The sweep of the reference: the default sweep's settings on a grid pinned here (not the
#: default grid, which may change), read by the row test and by check_sweep.
REFERENCE_SWEEP = SweepSpec(phi1=Grid(6.0, 31.0, 41), phi2=Grid(4.0, 56.0, 41))
#: Optics gaps, mm.
GAPS = np.linspace(0.0, 3.0, 61)


def preset_values() -> dict[str, np.ndarray]:
    """Solver, datasheet and optics values keyed 'preset/what/field'."""
    out = {}
    for name in PRESETS:
        d = preset(name)
        model = build_beam_model(d)
        for how, kwargs in (("travel", {}), ("force", {"target_force_N": 0.5})):
            r = solve(model, **kwargs)
            for f in SOLVE_FIELDS:
                out[f"{name}/{how}/{f}"] = np.asarray(getattr(r, f), dtype=float)
            out[f"{name}/{how}/hinge_rotation_deg"] = np.array(list(r.hinge_rotation_deg.values()))
        sensor = build_sensor(d)
        for k, v in dataclasses.asdict(datasheet(sensor, material=d.material.name)).items():
            if isinstance(v, (int, float)):
                out[f"{name}/datasheet/{k}"] = np.asarray(float(v))
        for k, v in dataclasses.asdict(cross_axis(d, sensor.input_travel_mm)).items():
            out[f"{name}/cross_axis/{k}"] = np.asarray(v, dtype=float)
    setup = OpticsSetup()
    for model in MODELS:
        out[f"optics/{model}/volts"] = output_voltage(GAPS, setup, model)
        out[f"optics/{model}/slope"] = voltage_slope(GAPS, setup, model)
        w = working_range(setup, 1.0, model)
        out[f"optics/{model}/working_range"] = np.array([w.gap_lo_mm, w.gap_hi_mm, w.slope_V_per_mm,
                                                         w.nonlinearity_pct])
    return out


def sweep_values(ds) -> dict[str, np.ndarray]:
    """The default sweep's qualifiers (proposed and basis), feasibility and reason kinds."""
    out = {}
    for k in QUALIFIERS:
        out[f"sweep/{k}"] = ds[k].values.astype(float)
        out[f"sweep/basis_{k}"] = ds[f"basis_{k}"].values.astype(float)
    out["sweep/feasible"] = ds["feasible"].values.astype(bool)
    out["sweep/reason_kind"] = np.vectorize(lambda s: str(s).split(":")[0])(ds["reason"].values).astype(str)
    return out


def main():
    ds, _ = run_sweep(REFERENCE_SWEEP, "reference", workers=1)
    values = {**preset_values(), **sweep_values(ds)}
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                            check=True).stdout.strip()
    PATH.parent.mkdir(exist_ok=True)
    np.savez_compressed(PATH, **values, commit=np.array(commit))
    print(f"wrote {len(values)} arrays to {PATH} (code at {commit})")


if __name__ == "__main__":
    main()
