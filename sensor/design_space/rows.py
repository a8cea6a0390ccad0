"""One row of a sweep: the basis body at one phi1 and the proposed body at every phi2,
solved together as a batch (one topology), with optional Monte-Carlo hinge scatter; the
row of the first hinge set also solves the basis family at its phi1 (the basis body with
hinges 1-8 of every thickness of :meth:`SweepSpec.family_thickness_mm`, DESIGN section 13)."""

from __future__ import annotations

import numpy as np

from geometry.checks import check_designs
from geometry.params import HINGE_SETS
from geometry.topology import build_beam_model
from sensor.design_space.dataset import BODY, FAMILY, MC_QUALIFIERS, mc_statistic
from sensor.design_space.resolution import resolutions_N
from sensor.design_space.scatter import as_cut
from sensor.design_space.spec import SweepSpec
from sensor.mechanics.qualifiers import Qualifiers, qualify
from sensor.mechanics.solver import SolverOptions, solve_batch
from sensor.mechanics.stress import stress_checks


def _cell_seed(seed: int, hinges: str, i: int, j: int) -> np.random.Generator:
    """A generator that depends only on the cell, not on how rows were scheduled."""
    return np.random.default_rng([seed, list(HINGE_SETS).index(hinges), i, j])


def _evaluate(designs, spec: SweepSpec, opts: SolverOptions):
    """Solve designs of one topology: ({variable of :data:`BODY`: array}, errors), NaN where
    a solve failed. Beside the qualifiers: the datasheet resolution and the stress
    utilisation (largest hinge peak stress at full scale / allowable stress)."""
    models = [build_beam_model(d) for d in designs]
    res, errs = solve_batch(models, target_output_mm=spec.target_output_mm, options=opts)
    q = [qualify(r, spec.law) if r is not None else Qualifiers.missing() for r in res]
    out = {k: np.array([getattr(x, k) for x in q], dtype=float) for k in Qualifiers.names()}
    out["resolution_N"] = resolutions_N([None if r is None else (r.force_N, r.output_mm) for r in res],
                                        [d.fiber_clearance_mm for d in designs])
    solved = [n for n, r in enumerate(res) if r is not None]
    out["stress_utilisation"] = np.full(len(designs), np.nan)
    if solved:
        checks = stress_checks([designs[n] for n in solved], [models[n] for n in solved], [res[n] for n in solved])
        out["stress_utilisation"][solved] = [c.utilisation for c in checks]
    assert set(out) == set(BODY)
    return out, errs


def solve_row(spec: SweepSpec, hinges: str, i: int, todo: np.ndarray | None = None) -> dict:
    """Solve row i (one phi1) of a hinge set: the basis body and the cells ``todo`` (bool
    mask over phi2; default all). Pure: depends only on its arguments."""
    phi1 = float(spec.phi1.values[i])
    phi2s = spec.phi2.values
    todo = np.ones(len(phi2s), bool) if todo is None else np.asarray(todo, bool)
    opts = SolverOptions()
    row = {"hinges": hinges, "i": i, "computed": todo.copy(),
           "reason": np.array([""] * len(phi2s), dtype=object)}
    # the reference: the basis body with this phi1, and the proposed body at each phi2
    basis = spec.design(hinges, phi1, None)
    cells_todo = np.flatnonzero(todo)
    proposed = [spec.design(hinges, phi1, phi2s[j]) for j in cells_todo]
    basis_report, *reports = check_designs([basis, *proposed])
    fail = basis_report.first_failure
    if fail is None:
        vals, err = _evaluate([basis], spec, opts)
        row["basis"] = {k: float(v[0]) for k, v in vals.items()}
        basis_reason = "" if err[0] is None else f"basis: {err[0]}"
    else:
        row["basis"] = {k: np.nan for k in BODY}
        basis_reason = f"basis infeasible: {fail.rule}: {fail.message}"
    row["basis_reason"] = basis_reason
    designs, cells = [], []
    for j, d, report in zip(cells_todo, proposed, reports):
        fail = report.first_failure
        if fail is not None:
            row["reason"][j] = f"{fail.rule}: {fail.message}"
        else:
            designs.append(d)
            cells.append(j)
    q = {k: np.full(len(phi2s), np.nan) for k in BODY}
    if designs:
        vals, errs = _evaluate(designs, spec, opts)
        for n, j in enumerate(cells):
            if errs[n] is not None:
                row["reason"][j] = f"solver: {errs[n]}"
            for k in BODY:
                q[k][j] = vals[k][n]
    row["proposed"] = q
    if spec.monte_carlo:
        row["mc"] = _monte_carlo_row(spec, hinges, i, designs, cells, len(phi2s), opts)
    if hinges == spec.hinge_sets[0]:
        row["family"] = basis_family(spec, phi1, opts)
    return row


def basis_family(spec: SweepSpec, phi1: float, opts: SolverOptions = SolverOptions()) -> dict[str, np.ndarray]:
    """The basis body at ``phi1`` with hinges 1-8 of each thickness of the family grid:
    {variable of :data:`FAMILY`: array over the thicknesses}, NaN where a body breaks a
    feasibility rule or does not solve."""
    ts = spec.family_thickness_mm()
    out = {k: np.full(len(ts), np.nan) for k in FAMILY}
    designs = [spec.family_design(phi1, t) for t in ts]
    ok = [n for n, report in enumerate(check_designs(designs)) if report.feasible]
    if ok:
        vals, _ = _evaluate([designs[n] for n in ok], spec, opts)
        for k in FAMILY:
            out[k][ok] = vals[k]
    return out


def _monte_carlo_row(spec, hinges, i, designs, cells, n_phi2, opts) -> dict:
    """Each feasible cell repeated with hinge thicknesses drawn around the nominal.

    A draw with a hinge thinner than the process can hold (``min_feature_mm``) is a part
    that could not be made, and a draw the solver cannot take to the target travel is one
    that would not work: both count against the cell's yield and stay out of the statistics.
    """
    stats = {mc_statistic(k, s): np.full(n_phi2, np.nan) for k in MC_QUALIFIERS for s in ("mean", "std", "tail")}
    stats["mc_yield"] = np.full(n_phi2, np.nan)
    for d, j in zip(designs, cells):
        z = _cell_seed(spec.seed, hinges, i, j).standard_normal((spec.monte_carlo, len(d.hinge_thickness_mm)))
        res = as_cut(d, z, spec.hinge_sd_mm, travel_mm=spec.target_output_mm, options=opts).results
        stats["mc_yield"][j] = sum(r is not None for r in res) / spec.monte_carlo
        q = [qualify(r, spec.law) for r in res if r is not None]
        for k in MC_QUALIFIERS:
            v = np.array([getattr(x, k) for x in q], dtype=float)
            v = v[np.isfinite(v)]
            if len(v):
                stats[mc_statistic(k, "mean")][j] = v.mean()
                stats[mc_statistic(k, "std")][j] = v.std(ddof=1) if len(v) > 1 else 0.0
                # robust value: the worse tail (10th percentile of goods, 90th of hysteresis)
                stats[mc_statistic(k, "tail")][j] = np.percentile(v, 90 if k == "hysteresis" else 10)
    return stats
