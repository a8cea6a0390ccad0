"""Range-targeted design (DESIGN section 13): the body of a given force range with the
lowest predicted hysteresis, by differential evolution (:func:`scipy.optimize.differential_evolution`).

Variables: phi1, phi2 (the proposed body) and the in-plane thickness of each mirror-symmetric
hinge pair of Figure 48, (1, 8), (2, 7), (3, 6), (4, 5), (9, 12), (10, 11) (the basis body:
phi1 and the first four pairs). The range constraint is met exactly rather than penalised:
the optimiser moves the pairs' thickness *ratios*, and every candidate's thicknesses are
scaled together until its range (input force at the target output travel) is within
``RANGE_TOLERANCE`` of the target (range grows about as t^3: a secant iteration in log-log,
3-4 solves). Every candidate is then held to every feasibility rule of
:func:`geometry.checks.check_design`, the hinge bounds and the allowable hinge stress at
full scale (:func:`sensor.mechanics.stress.stress_check`); one that breaks a rule scores
``PENALTY`` plus its violation, so the population is drawn to the feasible region.

Objective: the predicted hysteresis H (strain-energy law, section 6.2.5); candidates whose H
is within ``TIE`` of the best are ranked by resolution (:mod:`sensor.design_space.resolution`).
With ``robust_sd_mm`` it maximises instead the 10th percentile of quality (sensitivity / H)
over ``draws`` Monte-Carlo draws of every hinge thickness (normal, SD in mm; the same draws
for every candidate, from ``seed``), subject to at least ``min_yield`` of the draws being
cuttable (every used hinge >= min_feature_mm).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import differential_evolution, minimize

from geometry.checks import check_design, phi1_limit_deg
from geometry.params import Design, design_from_dict
from geometry.topology import build_beam_model
from sensor.design_space.resolution import resolution_N
from sensor.errors import DesignError, SolverError
from sensor.mechanics.hysteresis import DEFAULT_LAW, StrainEnergyLaw
from sensor.mechanics.qualifiers import qualify
from sensor.mechanics.solver import SolverOptions, solve_batch
from sensor.mechanics.stress import stress_check
from sensor.validation import Number

#: Mirror-symmetric hinge pairs of Figure 48 (hinge numbers; DESIGN section 3).
PAIRS = ((1, 8), (2, 7), (3, 6), (4, 5), (9, 12), (10, 11))
BASIS_PAIRS = PAIRS[:4]
#: Relative range error the thickness scaling stops at for the answer (the constraint is
#: 1 %), and while searching: there H and the stress utilisation are carried to the target
#: range by their scaling at fixed shape (H ~ SE ~ range / A, stress ~ t ~ range^(1/3)),
#: which saves a solve or two per candidate; the answer is matched again to RANGE_TOLERANCE.
RANGE_TOLERANCE = 1e-3
SEARCH_TOLERANCE = 0.03
RANGE_ITERATIONS = 8
#: Score of a candidate that breaks a rule: PENALTY + its violation (H is below 1).
PENALTY = 10.0
#: Candidates within this relative H of the best are ranked by resolution; the best
#: FINALISTS of the search are matched to the range exactly before the choice.
TIE = 1e-3
FINALISTS = 8
#: A range this far outside :func:`reachable_range`'s estimate (uniform hinges on a coarse
#: grid of angles) is refused before the search: unequal hinges reach further.
REACH_MARGIN = 3.0
#: Angle bounds (deg): phi1 up to the side links' limit, phi2 as the sweep's default grid.
PHI1_MIN, PHI2_BOUNDS = 2.0, (2.0, 60.0)

_RANGE = Number(0.0, 1e4, lo_open=True, unit="N")
_THICKNESS = Number(0.0, 10.0, lo_open=True, unit="mm")
_YIELD = Number(0.0, 1.0)
_SD = Number(0.0, 1.0, unit="mm")


@dataclass(frozen=True)
class DesignProblem:
    """A range-targeted design problem (mm, N). ``body``: "proposed" or "basis";
    ``pairs``: the hinge groups that share one thickness (default the mirror pairs; one
    group of every hinge gives the reduced problem of the angles alone); ``base``: other
    Design fields; ``hinge_min_mm`` defaults to the base design's ``min_feature_mm`` and
    ``hinge_max_mm`` to its ``link_width_mm`` (a hinge is a neck of its link)."""

    range_N: float
    target_output_mm: float = 1.0
    body: str = "proposed"
    hinge_min_mm: float | None = None
    hinge_max_mm: float | None = None
    pairs: tuple[tuple[int, ...], ...] | None = None
    robust_sd_mm: float = 0.0
    min_yield: float = 0.9
    draws: int = 32
    seed: int = 0
    base: dict = field(default_factory=dict)
    law: StrainEnergyLaw = DEFAULT_LAW

    def __post_init__(self):
        _RANGE.check("range_N", self.range_N, DesignError)
        if self.body not in ("proposed", "basis"):
            raise DesignError(f"body = {self.body!r}: must be 'proposed' or 'basis'")
        ref = self.reference()
        Number(0.0, ref.height_mm, lo_open=True, unit="mm, at most the body's height").check(
            "target_output_mm", self.target_output_mm, DesignError)
        if not self.target_output_mm < ref.fiber_clearance_mm:
            raise DesignError(f"target_output_mm = {self.target_output_mm:g}: must be below fiber_clearance_mm = "
                              f"{ref.fiber_clearance_mm:g} mm (the mirror must not touch the fiber)")
        if self.hinge_min_mm is None:
            object.__setattr__(self, "hinge_min_mm", ref.min_feature_mm)
        if self.hinge_max_mm is None:
            object.__setattr__(self, "hinge_max_mm", ref.link_width_mm)
        for name in ("hinge_min_mm", "hinge_max_mm"):
            _THICKNESS.check(name, getattr(self, name), DesignError)
        if self.hinge_min_mm < ref.min_feature_mm:
            raise DesignError(f"hinge_min_mm = {self.hinge_min_mm:g}: must be >= min_feature_mm = "
                              f"{ref.min_feature_mm:g} mm (what the cutting process can hold)")
        if not self.hinge_max_mm > self.hinge_min_mm:
            raise DesignError(f"hinge_max_mm = {self.hinge_max_mm:g}: must exceed hinge_min_mm = "
                              f"{self.hinge_min_mm:g} mm")
        _SD.check("robust_sd_mm", self.robust_sd_mm, DesignError)
        _YIELD.check("min_yield", self.min_yield, DesignError)
        Number(2, 10_000, integer=True).check("draws", self.draws, DesignError)
        Number(0, 2**32 - 1, integer=True).check("seed", self.seed, DesignError)
        if self.pairs is None:
            object.__setattr__(self, "pairs", BASIS_PAIRS if self.body == "basis" else PAIRS)
        used = set(range(1, 9 if self.body == "basis" else 13))
        if sorted(h for g in self.pairs for h in g) != sorted(used):
            raise DesignError(f"pairs = {self.pairs!r}: must group each used hinge "
                              f"({min(used)}-{max(used)}) exactly once")

    def reference(self) -> Design:
        """The base design (angles and hinges to be chosen)."""
        base = {k: v for k, v in self.base.items() if k not in ("phi1_deg", "phi2_deg", "hinge_set",
                                                                "hinge_thickness_mm", "name", "body")}
        return design_from_dict({**base, "phi1_deg": 20.0, "phi2_deg": None if self.body == "basis" else 30.0,
                                 "hinge_set": "optimised", "hinge_thickness_mm": [0.5] * 12}, source="design base")

    @property
    def n_angles(self) -> int:
        return 1 if self.body == "basis" else 2

    def bounds(self) -> list[tuple[float, float]]:
        """Bounds of the variables: the angles (deg), then log(t_k / t_0) of every pair but the first."""
        span = math.log(self.hinge_max_mm / self.hinge_min_mm)
        angles = [(PHI1_MIN, phi1_limit_deg(self.reference()))] + ([PHI2_BOUNDS] if self.body == "proposed" else [])
        return angles + [(-span, span)] * (len(self.pairs) - 1)

    def design(self, x, scale_mm: float, name: str = "optimised") -> Design:
        """The design of variables ``x`` with the first pair ``scale_mm`` thick."""
        ref = self.reference()
        t = np.array(ref.hinge_thickness_mm)
        ratios = np.exp(np.concatenate([[0.0], np.asarray(x[self.n_angles:], dtype=float)]))
        for group, r in zip(self.pairs, ratios):
            for h in group:
                t[h - 1] = scale_mm * r
        if self.body == "basis":
            t[8:] = ref.hinge_thickness_mm[8:]
        return ref.replace(phi1_deg=float(x[0]), phi2_deg=None if self.body == "basis" else float(x[1]),
                           hinge_thickness_mm=tuple(float(v) for v in t), name=name)


@dataclass(frozen=True)
class Candidate:
    """One evaluated candidate: its variables, the range-matched design, and the score."""

    x: tuple[float, ...]
    design: Design | None
    score: float
    range_N: float = math.nan
    hysteresis: float = math.nan
    resolution_N: float = math.nan
    stress_utilisation: float = math.nan
    quality_p10_mm_per_N: float = math.nan
    yield_fraction: float = math.nan
    reason: str = ""


def _used(design: Design) -> np.ndarray:
    return np.array(design.hinge_thickness_mm[:8] if design.is_basis else design.hinge_thickness_mm)


def _match_range(problem: DesignProblem, X: np.ndarray, tolerance: float) -> list[tuple[Design | None, object, str]]:
    """Scale each candidate's thicknesses until its range is within ``tolerance`` of the
    target: per row of X, (design, solve result, '' or why it failed)."""
    n = len(X)
    ref_t = math.sqrt(problem.hinge_min_mm * problem.hinge_max_mm) / 2
    scale = np.full(n, ref_t)
    prev = [None] * n                     # (log scale, log range) of the last solve
    out: list = [(None, None, "range not matched")] * n
    alive = list(range(n))
    opts = SolverOptions()
    for _ in range(RANGE_ITERATIONS):
        if not alive:
            break
        designs, models, keep = [], [], []
        for k in alive:
            try:
                d = problem.design(X[k], scale[k])
                models.append(build_beam_model(d))
            except Exception as exc:      # a geometry the builder refuses is a failed candidate
                out[k] = (None, None, f"geometry: {' '.join(str(exc).split())[:120]}")
                continue
            designs.append(d)
            keep.append(k)
        if not keep:
            break
        try:
            res, errs = solve_batch(models, target_output_mm=problem.target_output_mm, options=opts)
        except SolverError as exc:
            res, errs = [None] * len(keep), [exc] * len(keep)
        alive = []
        for k, d, r, e in zip(keep, designs, res, errs):
            if r is None:
                out[k] = (d, None, f"solver: {e}")
                continue
            lr, ls = math.log(r.input_force_N), math.log(scale[k])
            err = lr - math.log(problem.range_N)
            out[k] = (d, r, "")
            if abs(err) <= math.log1p(tolerance):
                continue
            slope = 3.0 if prev[k] is None or prev[k][0] == ls else (lr - prev[k][1]) / (ls - prev[k][0])
            slope = min(max(slope, 1.0), 5.0)
            prev[k] = (ls, lr)
            scale[k] = math.exp(ls - err / slope)
            out[k] = (d, r, "range not matched")
            alive.append(k)
    return out


def evaluate(problem: DesignProblem, X, tolerance: float = RANGE_TOLERANCE) -> list[Candidate]:
    """Evaluate candidates (rows of X): range-matched within ``tolerance``, checked, scored
    (pure: safe to run on any worker)."""
    X = np.atleast_2d(np.asarray(X, dtype=float))
    # the thicknesses scale together: their spread is the ratios' whatever the range, so a
    # spread beyond hinge_max / hinge_min fails the hinge bounds without a solve
    ratios = X[:, problem.n_angles:]
    spread = np.ptp(np.concatenate([np.zeros((len(X), 1)), ratios], axis=1), axis=1)
    excess = spread - math.log(problem.hinge_max_mm / problem.hinge_min_mm)
    fits = np.flatnonzero(excess <= 0)
    matched = dict(zip(fits, _match_range(problem, X[fits], tolerance)))
    out = []
    rng = np.random.default_rng(problem.seed)
    z = rng.standard_normal((problem.draws, 12)) if problem.robust_sd_mm > 0 else None
    for n, x in enumerate(X):
        x = tuple(float(v) for v in x)
        if n not in matched:
            out.append(Candidate(x, None, PENALTY + 1.0 + min(excess[n], 1.0),
                                 reason=f"hinge bounds: thickness ratio {math.exp(spread[n]):.2f} > "
                                        f"hinge_max_mm / hinge_min_mm"))
            continue
        d, r, why = matched[n]
        if why:
            out.append(Candidate(x, d, PENALTY + 2.0, reason=why))
            continue
        q = qualify(r, problem.law)
        to_target = problem.range_N / q.range_N          # 1 within the tolerance
        t = _used(d) * to_target ** (1 / 3)
        bound = max(problem.hinge_min_mm - t.min(), t.max() - problem.hinge_max_mm, 0.0)
        fail = check_design(d).first_failure
        util = stress_check(d, build_beam_model(d), r).utilisation * to_target ** (1 / 3)
        common = dict(range_N=q.range_N, hysteresis=q.hysteresis * to_target, stress_utilisation=util,
                      resolution_N=resolution_N(r.force_N, r.output_mm, d.fiber_clearance_mm) * to_target)
        if bound > 0 or fail is not None or util > 1.0:
            reason = (f"hinge bounds: thickness {t.min():.3f}-{t.max():.3f} mm" if bound > 0 else
                      f"{fail.rule}: {fail.message}" if fail is not None else f"stress: {util:.3f} x allowable")
            violation = bound / problem.hinge_min_mm + max(util - 1.0, 0.0) + (1.0 if fail is not None else 0.0)
            out.append(Candidate(x, d, PENALTY + min(violation, 1.0), reason=reason, **common))
            continue
        if z is None:
            out.append(Candidate(x, d, q.hysteresis, **common))
            continue
        p10, yld = _robust(problem, d, z)
        score = -p10 if yld >= problem.min_yield and np.isfinite(p10) else PENALTY + (problem.min_yield - yld)
        out.append(Candidate(x, d, score, quality_p10_mm_per_N=p10, yield_fraction=yld,
                             reason="" if score < PENALTY else f"yield {yld:.2f} < min_yield", **common))
    return out


def _robust(problem: DesignProblem, d: Design, z: np.ndarray) -> tuple[float, float]:
    """(10th percentile of quality over the draws that can be cut and solve, mm/N; the
    fraction of draws that can be cut)."""
    nominal = np.array(d.hinge_thickness_mm)
    draws = nominal + problem.robust_sd_mm * z
    used = slice(None, 8) if d.is_basis else slice(None)
    cuttable = draws[:, used].min(axis=1) >= d.min_feature_mm
    models = [build_beam_model(d.replace(hinge_thickness_mm=tuple(t))) for t in draws[cuttable]]
    res, _ = solve_batch(models, target_output_mm=problem.target_output_mm) if models else ([], [])
    qual = [qualify(r, problem.law).quality_mm_per_N for r in res if r is not None]
    p10 = float(np.percentile(qual, 10)) if qual else math.nan
    return p10, float(cuttable.mean())


def _evaluate_chunk(args) -> list[Candidate]:
    problem, X, tolerance = args
    return evaluate(problem, X, tolerance)


@dataclass(frozen=True)
class DesignResult:
    """The optimiser's answer: the best candidate, how many were evaluated, in how long."""

    best: Candidate
    problem: DesignProblem
    evaluations: int
    seconds: float


def optimise(problem: DesignProblem, pool=None, popsize: int = 6, maxiter: int = 50,
             tol: float = 1e-3, polish_evaluations: int = 200) -> DesignResult:
    """Differential evolution (deterministic for a given ``problem.seed``) over the angles
    and the pair-thickness ratios, then a bounded Powell search from its best (the optimum
    usually has pairs at the hinge bounds, where a population converges slowly); ``pool``
    a :class:`~sensor.design_space.execution.TaskPool` (default: in this process). Raises
    :class:`DesignError` naming the reachable interval when no candidate is feasible."""
    t0 = time.monotonic()
    reach = reachable_range(problem)
    if not (reach[0] / REACH_MARGIN <= problem.range_N <= reach[1] * REACH_MARGIN):
        raise DesignError(unreachable_message(problem, reach))
    archive: list[Candidate] = []

    def scores(X):                        # X: (variables, candidates)
        rows = np.asarray(X).T
        if pool is None or pool.size <= 1 or len(rows) == 1:
            cands = evaluate(problem, rows, SEARCH_TOLERANCE)
        else:
            chunks = np.array_split(rows, min(len(rows), 2 * pool.size))
            cands = [c for part in pool.map(_evaluate_chunk, [(problem, ch, SEARCH_TOLERANCE) for ch in chunks])
                     for c in part]
        archive.extend(cands)
        return np.array([c.score for c in cands])

    bounds = problem.bounds()
    de = differential_evolution(scores, bounds, popsize=popsize, maxiter=maxiter, tol=tol,
                                seed=problem.seed, vectorized=True, updating="deferred", polish=False,
                                init="latinhypercube", mutation=(0.5, 1.0), recombination=0.7)
    if polish_evaluations and de.fun < PENALTY:
        minimize(lambda x: scores(np.asarray(x)[:, None])[0], de.x, method="Powell", bounds=bounds,
                 options={"maxfev": polish_evaluations, "xtol": 1e-3, "ftol": 1e-5})
    # the answer: the best few candidates matched to the range exactly, ties by resolution
    order = sorted((c for c in archive if c.score < PENALTY), key=lambda c: c.score)
    finalists = [c for c in evaluate(problem, np.array([c.x for c in order[:FINALISTS]]).reshape(-1, len(bounds)))
                 if c.score < PENALTY] if order else []
    if not finalists:
        raise DesignError(unreachable_message(problem, reach))
    best = min(c.score for c in finalists)
    ties = [c for c in finalists if c.score <= best + TIE * abs(best)]
    choice = min(ties, key=lambda c: (c.resolution_N, c.score))
    return DesignResult(choice, problem, len(archive) + len(order[:FINALISTS]), time.monotonic() - t0)


def unreachable_message(problem: DesignProblem, reach: tuple[float, float]) -> str:
    """The one line for a range no feasible body reaches, naming about where they do."""
    lo, hi = reach
    return (f"range_N = {problem.range_N:g}: no {problem.body} body within the feasibility rules, "
            f"hinges {problem.hinge_min_mm:g}-{problem.hinge_max_mm:g} mm and the allowable stress reaches "
            f"it at {problem.target_output_mm:g} mm travel; with equal hinges they reach about {lo:.3g} to "
            f"{hi:.3g} N (unequal hinges somewhat further)")


def reachable_range(problem: DesignProblem, n: int = 7) -> tuple[float, float]:
    """About the smallest and largest range (N) of feasible bodies within the stress limit:
    a coarse grid of angles, every hinge at hinge_min_mm (smallest range) and at the
    thickness where the stress utilisation reaches 1 or hinge_max_mm (largest)."""
    ref = problem.reference()
    phi1s = np.linspace(PHI1_MIN + 3, phi1_limit_deg(ref) - 0.2, n)
    phi2s = np.linspace(*PHI2_BOUNDS, n) if problem.body == "proposed" else [None]
    designs = []
    for p1 in phi1s:
        for p2 in phi2s:
            x = [p1] + ([] if p2 is None else [p2]) + [0.0] * (len(problem.pairs) - 1)
            d = problem.design(x, problem.hinge_min_mm)
            if check_design(d).feasible:
                designs.append(d)
    lows, highs = [], []
    for d in designs:
        res, _ = solve_batch([build_beam_model(d)], target_output_mm=problem.target_output_mm)
        if res[0] is None:
            continue
        util = stress_check(d, build_beam_model(d), res[0]).utilisation
        if util > 1:
            continue
        lows.append(res[0].input_force_N)
        t = min(problem.hinge_max_mm, problem.hinge_min_mm / util)
        thick = d.replace(hinge_thickness_mm=tuple(t if i < (8 if d.is_basis else 12) else v
                                                   for i, v in enumerate(d.hinge_thickness_mm)))
        if check_design(thick).feasible:
            r2, _ = solve_batch([build_beam_model(thick)], target_output_mm=problem.target_output_mm)
            if r2[0] is not None:
                highs.append(r2[0].input_force_N)
    if not lows:
        return math.nan, math.nan
    return min(lows), max(highs + lows)


def describe(design: Design, problem: DesignProblem) -> dict:
    """The numbers of a design at the problem's travel, from a fresh solve (the datasheet's
    resolution from the full sensor model): the keys of ``dacm design --json``."""
    from dataclasses import asdict

    from geometry.params import design_to_dict
    from sensor.readout.datasheet import datasheet
    from sensor.readout.sensor_model import build_sensor

    model = build_beam_model(design)
    r = solve_batch([model], target_output_mm=problem.target_output_mm)[0][0]
    if r is None:
        raise DesignError(f"design {design.name}: does not solve to the travel {problem.target_output_mm:g} mm")
    q = qualify(r, problem.law)
    sheet = datasheet(build_sensor(design, law=problem.law, target_output_mm=problem.target_output_mm),
                      material=design.material.name)
    return {"design": design_to_dict(design), "range_N": q.range_N, "hysteresis": q.hysteresis,
            "resolution_N": sheet.resolution_N, "amplification": q.amplification,
            "k_out_N_per_mm": q.k_out_N_per_mm, "strain_energy_mJ": q.strain_energy_mJ,
            "stress_utilisation": stress_check(design, model, r).utilisation,
            "quality_mm_per_N": q.quality_mm_per_N, "datasheet": asdict(sheet)}
