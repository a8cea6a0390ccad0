"""Robust design under the process' as-cut scatter (DESIGN sections 13 and 16): minimise the
median hysteresis of the parts cut from a drawing, subject to chance constraints

    P(peak stress > allowable) <= STRESS_PROBABILITY   (the 95th percentile of utilisation <= 1)
    range 5th percentile >= (1 - BAND) N and 95th percentile <= (1 + BAND) N
    yield >= min_yield                                  (every hinge >= min_feature_mm)
    median H < H_LIMIT                                  (the hysteresis law's domain)
    the drawing off the toggle                          (``off_toggle`` problems only)

for the process (:class:`geometry.process.Process`: every hinge drawn + offset + N(0, SD)).
The search reads a candidate's parts off its response surface
(:mod:`sensor.design_space.surrogate`: 13 solves for the DACM, then the percentiles over SURFACE_DRAWS
quasi-random draws that are the same for every candidate and every seed, so the first pass
does not depend on the report's seed). The percentiles are Harrell-Davis estimates over the
draws weighted by their smoothed chance of being made
(:meth:`~sensor.design_space.surrogate.ResponseSurface.weighted_parts`,
:func:`~sensor.design_space.surrogate.smooth_percentile`), so they are smooth in the drawing
and their forward differences are gradients, not the jumps of one draw. The yield is exact:
prod_i Phi((t_i + offset - min_feature) / SD). Method: SLSQP with forward differences in the
same unit box, in trust-region boxes (:func:`_search`: an elastic phase from a start that
misses the constraints, then down the median H subject to them), from the nominal answer
(:func:`sensor.design_space.optimise.optimise`) and, where that one is next to the toggle,
also from the answer off it (:func:`_starts`), side by side in the pool; each end is rounded
inward and its tolerance report (a Monte Carlo of the report's draws and seed) computed,
where a range band off-centre is centred by scaling every hinge together (:func:`_centred`).
Where it still misses a chance
constraint on the report's parts or for the process (the surface's draws:
:func:`_process_misses`), the search runs again from it with tighter margins
(SEARCH_PASSES), on the same draws of the surface. The written design that misses least is
kept, then the one of lower median H.

With sample percentiles (np.percentile over the parts that can be made) and a phase one to
the deepest point inside the constraints, the search ran out its boxes at the iteration
limit and where it ended hung on its start: the 5 N nominal answer with phi2 one quantum
(0.01 deg) off ended at median H 0.0575 or 0.0397 against 0.0419 (stop 57). With the
smooth reading and the elastic phase (stop 58), all three end at 0.0377-0.0379
(tests/design_space/test_tolerance.py checks it).

The Monte Carlo search this replaced (64 of the report's parts a candidate) ended on the
edge of the report's sample: its 5, 10 and 15 N answers kept their constraints on the 200
parts of the report and missed them for the process (10 N: P(stress) 5.9 %, 95th range
percentile 11.008 N, on 4096 draws of the surface), and its 10 N answer moved from median
H 0.059 to 0.073 with a 1 % change of the model.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from scipy.optimize import minimize
from scipy.stats import norm
from threadpoolctl import threadpool_limits

from geometry.params import Design
from sensor.design_space.optimise import (
    OBJECTIVE_SCALE,
    STRESS_SLACK,
    DesignProblem,
    evaluate,
    optimise,
    solve_designs,
    toggle_miss,
    toggle_rows,
    written,
)
from sensor.design_space.surrogate import response_surface, smooth_percentile, surface_draws
from sensor.design_space.tolerance import DRAWS, Tolerance, tolerance
from sensor.errors import DesignError
from sensor.mechanics.hysteresis import H_LIMIT
from sensor.mechanics.toggle import design_stroke_change

STRESS_PROBABILITY, BAND, MIN_YIELD = 0.05, 0.10, 0.9
#: The search reads each candidate's parts off its response surface over SURFACE_DRAWS
#: quasi-random draws (:func:`sensor.design_space.surrogate.surface_draws`; a 5th percentile
#: of 4096 is within about 0.3 % of the process' own) and holds the range band to SEARCH_BAND
#: and P(stress) to SEARCH_STRESS_PROBABILITY, a little inside BAND and STRESS_PROBABILITY
#: for the rounding of the written drawing; at most ITERATIONS SLSQP iterations a box.
#: "For the process" is judged on the same surface (:func:`_process_misses`), which is
#: within 0.9 % of solved parts on the range percentiles, and on P(stress) within 0.01
#: where it is near 5 % (the robust answers, 200 common draws) and 0.016 where it is 45 %
#: (the 10 N nominal answer, 400; one-off runs, stop 57): more than the margins below.
#: Margins of 0.095 and 0.045 (to cover the surface's error of stop 54, 0.7 % and 0.03)
#: trapped the search: at 5 N it ended at median H 0.0658, against 0.0427 with these (stop 55)
#: (one-off runs).
SURFACE_DRAWS, SEARCH_BAND, SEARCH_STRESS_PROBABILITY, ITERATIONS = 4096, 0.0975, 0.0475, 30
#: The search's trust region (:func:`_search`): boxes of this half-width in the unit box,
#: at most this many of them, each at most ITERATIONS SLSQP iterations.
TRUST_RADIUS, TRUST_BOXES = 0.1, 8
#: Passes of the final centring of the range band (:func:`_centred`).
CENTRING_PASSES = 3
#: Where the written answer misses a chance constraint on the report's draws (a sample of 200
#: parts can miss where the process keeps it), the search runs once more from it on the same
#: surface draws with margins PASS_TIGHTENING tighter (band and P(stress)): SEARCH_PASSES = 2.
#: It ran on the report's own draws until this session; those drawings fitted the sample and
#: missed for the process (the 2 N answer's band 1.789-2.212 N on the surface's draws).
#: 0.01 covers a report whose 200 parts sit 1 % off the process (5 N, seed 2: 0.005 left its
#: 5th percentile just under 4.5 N, where the process' was inside; one-off runs, stop 58).
#: P(stress)'s margin tightens with it, 4.75 -> 3.75 %.
SEARCH_PASSES, PASS_TIGHTENING = 2, 0.01
#: The elastic phase's weight on the misses (log units), per OBJECTIVE_SCALE log H: above
#: the constraints' multipliers, so it ends on them, not short (at 10 it ended with the 5 N
#: range band 4 % short); and a point within FEASIBILITY_TOLERANCE of them keeps them (SLSQP's
#: own ends land there).
ELASTIC_WEIGHT, FEASIBILITY_TOLERANCE = 100 * OBJECTIVE_SCALE, 1e-6
#: Forward-difference step in the unit box, larger than the nominal search's: the percentiles
#: are smooth (:func:`~sensor.design_space.surrogate.smooth_percentile`) but the peak stress
#: keeps its kink where the governing hinge changes.
ROBUST_FD_STEP = 1e-4


@dataclass(frozen=True)
class RobustResult:
    design: Design
    tolerance: Tolerance
    met: bool
    why: str
    seconds: float


def _values(problem: DesignProblem, z_draws: np.ndarray, z: np.ndarray, min_yield: float,
            band: float, stress_probability: float) -> np.ndarray:
    """[log median SE-based H, then the constraints (>= 0 when met)] of variables z over the
    parts cut with deviates ``z_draws``, read off the drawing's response surface
    (:func:`sensor.design_space.surrogate.response_surface`): the parts' utilisation
    percentile at 1 - ``stress_probability`` and their range percentiles 5 and 95 within
    ``band`` of the range among them (weighted Harrell-Davis estimates over every draw,
    weighted by its smoothed chance of being made: smooth in the drawing); with
    ``off_toggle`` the drawing's own off-toggle rows (:func:`toggle_rows`) too."""
    d = problem.design(z)
    pr = problem.process
    t = np.array(d.used_thickness_mm)
    log_yield = float(np.sum(norm.logcdf((t + pr.offset_mm - d.min_feature_mm) / pr.sd_mm)))
    margin = 1.0 if problem.body == "basis" else (problem.domain.phi2_edge(z[0]) - z[1]) / 10.0
    toggle = toggle_rows(problem, evaluate(problem, z[None])[0]) if problem.off_toggle else ()
    surface = response_surface(d, pr, problem.travel_mm)
    s = surface.weighted_parts(z_draws, problem.law) if surface is not None else None
    if s is None or s["weight"].sum() < 0.5 * len(z_draws):
        return np.array([10.0, -10.0, -10.0, -10.0, log_yield - math.log(min_yield), margin, *toggle, -10.0])
    w = s["weight"]
    log_h = math.log(smooth_percentile(s["hysteresis"], w, 50))
    return np.array([log_h,
                     -math.log(max(smooth_percentile(s["utilisation"], w, 100 * (1 - stress_probability)), 1e-9)),
                     math.log(smooth_percentile(s["range_N"], w, 5) / ((1 - band) * problem.range_N)),
                     math.log((1 + band) * problem.range_N / smooth_percentile(s["range_N"], w, 95)),
                     log_yield - math.log(min_yield), margin, *toggle,
                     math.log(H_LIMIT) + math.log1p(-STRESS_SLACK) - log_h])   # the optimiser's margin


def _violation(problem: DesignProblem, tol: Tolerance) -> float:
    """The largest relative miss on the report ``tol`` of the range band, the stress
    probability and the median H against the hysteresis law's domain (<= 0: met)."""
    return max(_band_violation(problem, tol.range_N_p5, tol.range_N_p95, tol.p_over_stress),
               tol.hysteresis_fraction_p50 / H_LIMIT - 1)


def _band_violation(problem: DesignProblem, p5: float, p95: float, p_stress: float) -> float:
    """The largest relative miss of a range band (5th-95th percentiles, N) against +-BAND
    and of a stress probability against STRESS_PROBABILITY (<= 0: met)."""
    lo, hi = (1 - BAND) * problem.range_N, (1 + BAND) * problem.range_N
    return max(1 - p5 / lo, p95 / hi - 1, p_stress - STRESS_PROBABILITY)


def _process_violation(problem: DesignProblem, read: ProcessRead | None) -> float:
    """:func:`_band_violation` for the process (``read``: :func:`_process_read`'s; inf where
    the surface does not solve)."""
    return math.inf if read is None else _band_violation(problem, *read)


def _centred(problem: DesignProblem, d: Design, tol: Tolerance, draws: int, seed: int, name: str):
    """The written robust design with every hinge scaled together (within the bounds) until
    the geometric centre of its range band on the report's draws is the centre of the
    allowed band (range ~ t^3 at fixed shape; CENTRING_PASSES passes): the search saw
    the surface's draws, so its band can sit off-centre on the report's. A step is kept
    only if it lowers the largest miss on the report and does not make the process miss,
    or miss more (:func:`_process_violation`): a band that fills the allowed one, centred
    on the report's 200 parts, can leave it for the process. Returns (design, its report,
    its :func:`_process_read`)."""
    target = math.sqrt((1 - BAND) * (1 + BAND)) * problem.range_N
    read = _process_read(problem, d)
    best = (_violation(problem, tol), d, tol, read)
    for _ in range(CENTRING_PASSES):
        if best[0] <= 0:
            break
        _, d0, t0, r0 = best
        shift = math.log(target / math.sqrt(t0.range_N_p5 * t0.range_N_p95)) / 3.0
        z = problem.variables(d0)
        k = problem.n_angles
        z[k:] = np.clip(z[k:] + shift, problem.lower[k:], problem.upper[k:])
        d1 = written(problem, problem.design(z), name)
        t1 = tolerance(d1, problem.process, draws, seed, problem.travel_mm, problem.law)
        r1 = _process_read(problem, d1)
        miss = _violation(problem, t1)
        if miss >= best[0] or _process_violation(problem, r1) > max(_process_violation(problem, r0), 0.0):
            break
        best = (miss, d1, t1, r1)
    return best[1:]


def _check_domain(problem: DesignProblem, design: Design) -> None:
    """Raise DesignError if the written robust design's own predicted hysteresis is past the
    law's domain (its datasheet cannot be written): ranges near the top of the reach."""
    model, r = solve_designs([design], problem.travel_mm)[0]
    if model is None:
        raise DesignError(f"range_N = {problem.range_N:g}: the robust drawing does not solve ({r})")
    se = r.strain_energy_mJ
    if not problem.within_law(math.log(se)):
        raise DesignError(f"range_N = {problem.range_N:g}: no robust design inside the hysteresis law's domain "
                          f"(H < {H_LIMIT:g}): the search ended at a drawing whose strain energy is {se:.4g} mJ "
                          f"(past {problem.law.max_strain_energy_mJ:.4g}); the nominal design is inside it "
                          "(run without --robust)")


def _search(problem: DesignProblem, z_draws: np.ndarray, u0: np.ndarray, min_yield: float,
            band: float, stress_probability: float) -> np.ndarray:
    """SLSQP from u0 (unit box) on the parts cut with ``z_draws``, in boxes of half-width
    TRUST_RADIUS round the best point so far (a trust region: from a start that misses the
    chance constraints, one SLSQP run in the whole box jumps to wherever its first quadratic
    model points), for at most TRUST_BOXES boxes, each an elastic phase (objective plus
    ELASTIC_WEIGHT times the misses) from a point that misses the constraints or a descent
    subject to them from one that keeps them (within FEASIBILITY_TOLERANCE): the best
    point it saw that keeps the constraints (else the best by the elastic measure, inside
    the hysteresis law's domain where any point is). It stops when a descent ends inside its
    box (a local optimum) or a box ends where it began."""
    values: dict[bytes, np.ndarray] = {}
    grads: dict[bytes, np.ndarray] = {}

    def at(u):
        """The objective and constraints at u (one batch of parts), cached."""
        key = np.asarray(u).tobytes()
        if key not in values:
            values[key] = _values(problem, z_draws, problem.from_unit(u), min_yield, band, stress_probability)
        return values[key]

    def grad(u):
        """Their forward differences, only where SLSQP asks (not at line-search points)."""
        key = np.asarray(u).tobytes()
        if key not in grads:
            step = np.where(u + ROBUST_FD_STEP <= 1.0, ROBUST_FD_STEP, -ROBUST_FD_STEP)
            vals = np.array([_values(problem, z_draws, problem.from_unit(x), min_yield, band, stress_probability)
                             for x in u + np.diag(step)])
            grads[key] = (vals - at(u)).T / step
        return grads[key]

    def keeps(v):
        return v[1:].min() >= -FEASIBILITY_TOLERANCE

    def best():
        """The best point seen so far (see above): one that keeps the constraints by its
        median H, else by the elastic phase's own measure (so its end is kept)."""
        def rank(v):
            if keeps(v):
                return 0, v[0]
            return 1, -float(v[-1] >= 0), OBJECTIVE_SCALE * v[0] + ELASTIC_WEIGHT * np.maximum(-v[1:], 0.0).sum()
        return np.frombuffer(min(values, key=lambda k: rank(values[k])))

    def elastic(u, bounds):
        """Phase one: SLSQP on (u, s), minimising the objective plus ELASTIC_WEIGHT sum s
        subject to every constraint + s >= 0 and s >= 0 (the elastic mode of SNOPT: Gill,
        Murray and Saunders, SIAM Review 47, 2005): it walks to the constraints downhill."""
        n, m = len(u), len(at(u)) - 1
        minimize(lambda x: OBJECTIVE_SCALE * at(x[:n])[0] + ELASTIC_WEIGHT * x[n:].sum(),
                 np.append(u, np.maximum(-at(u)[1:], 0.0)),
                 jac=lambda x: np.concatenate([OBJECTIVE_SCALE * grad(x[:n])[0], np.full(m, ELASTIC_WEIGHT)]),
                 method="SLSQP", bounds=bounds + [(0.0, None)] * m,
                 constraints=[{"type": "ineq", "fun": lambda x: at(x[:n])[1:] + x[n:],
                               "jac": lambda x: np.column_stack([grad(x[:n])[1:], np.eye(m)])}],
                 options={"maxiter": ITERATIONS, "ftol": 1e-8})

    def descend(u, bounds):
        """Phase two: SLSQP on the objective subject to the constraints."""
        minimize(lambda x: OBJECTIVE_SCALE * at(x)[0], u, jac=lambda x: OBJECTIVE_SCALE * grad(x)[0],
                 method="SLSQP", bounds=bounds,
                 constraints=[{"type": "ineq", "fun": lambda x: at(x)[1:], "jac": lambda x: grad(x)[1:]}],
                 options={"maxiter": ITERATIONS, "ftol": 1e-8})

    u = np.asarray(u0, dtype=float)
    for _ in range(TRUST_BOXES):
        bounds = list(zip(np.maximum(u - TRUST_RADIUS, 0.0), np.minimum(u + TRUST_RADIUS, 1.0)))
        feasible = keeps(at(u))
        (descend if feasible else elastic)(u, bounds)
        end = best()
        moved = np.abs(end - u).max()
        u = end
        if moved == 0.0 or (feasible and moved < 0.5 * TRUST_RADIUS):   # stuck, or a local optimum
            break
    return best()


def _misses(problem: DesignProblem, d: Design, tol: Tolerance, min_yield: float) -> list[str]:
    """The chance constraints (and the off-toggle and domain rules) the written design ``d``
    misses on its tolerance report ``tol``, one phrase each (empty: met)."""
    why = _chance_misses(problem, tol.range_N_p5, tol.range_N_p95, tol.p_over_stress, "", ".3g")
    if tol.yield_fraction < min_yield:
        why.append(f"yield {100 * tol.yield_fraction:.1f} % < {100 * min_yield:g} %")
    if problem.off_toggle and (miss := toggle_miss(d, *solve_designs([d], problem.travel_mm)[0])):
        why.append(f"the drawing is {miss}")
    if not tol.hysteresis_fraction_p50 < H_LIMIT:
        why.append(f"median H {tol.hysteresis_fraction_p50:.3f} past the hysteresis law's domain (< {H_LIMIT:g})")
    return why


class ProcessRead(NamedTuple):
    """A drawing's parts for the process (:func:`_process_read`)."""

    range_N_p5: float
    range_N_p95: float
    p_over_stress: float


def _process_read(problem: DesignProblem, d: Design) -> ProcessRead | None:
    """The range's 5th and 95th percentiles (N) and P(stress > allowable) of the written
    design ``d``'s parts for the process: on its response surface's SURFACE_DRAWS draws
    (sample percentiles over the parts that can be made); None where it does not solve."""
    surface = response_surface(d, problem.process, problem.travel_mm)
    if surface is None:
        return None
    s = surface.parts(surface_draws(SURFACE_DRAWS), problem.law)
    lo, hi = np.percentile(s["range_N"], [5, 95])
    return ProcessRead(float(lo), float(hi), float(np.mean(s["utilisation"] > 1.0)))


def _process_misses(problem: DesignProblem, d: Design, read: ProcessRead | None = None) -> list[str]:
    """The chance constraints the written design ``d`` misses for the process
    (``read``, else :func:`_process_read`): the range band outside +-BAND or P(stress) over
    STRESS_PROBABILITY, one phrase each (empty: met). The search holds tighter margins
    there; a drawing it could not bring inside them can still pass on the report's sample."""
    read = _process_read(problem, d) if read is None else read
    if read is None:
        return ["the response surface does not solve"]
    return _chance_misses(problem, *read, " for the process (response surface)", ".4g")


def _chance_misses(problem: DesignProblem, p5: float, p95: float, p_stress: float, where: str,
                   fmt: str) -> list[str]:
    """The phrases for P(stress) over STRESS_PROBABILITY and a range band (5th-95th
    percentiles, N) outside +-BAND, ``where`` said after each, the band's ends in ``fmt``."""
    why = []
    if p_stress > STRESS_PROBABILITY:
        why.append(f"P(stress > allowable) {100 * p_stress:.1f} %{where} > {100 * STRESS_PROBABILITY:g} %")
    if p5 < (1 - BAND) * problem.range_N or p95 > (1 + BAND) * problem.range_N:
        why.append(f"range band {p5:{fmt}}-{p95:{fmt}} N{where} outside +-{100 * BAND:g} % of {problem.range_N:g} N")
    return why


def _starts(problem: DesignProblem, nominal: Design, pool) -> list[Design]:
    """The drawings the robust search starts from (it is local): the nominal answer and,
    where that sits next to the toggle (:attr:`~sensor.mechanics.toggle.StrokeChange.near_toggle`;
    a DACM problem that does not keep off it already), the nominal answer of the same problem
    off the toggle. At 15 N the search ended at median H 0.1598 from the nominal answer and
    at 0.1142 from the off-toggle one (on the model before the oblique root's coupling,
    geometry.topology.ROOT_COUPLING_PER_LEAN). A third start, the nominal answer with its
    hinge minimum raised 0.06 mm (2.4 SD), took 5 N from 0.0427 to 0.0394 (stop 55's search;
    stop 58's reaches 0.0377 from the nominal answer alone) but doubled the
    search's time, past its 10 x the nominal search (tests/benchmarks/design.py: 12.9 x);
    not kept (one-off runs)."""
    if problem.body == "basis" or problem.off_toggle:
        return [nominal]
    if not design_stroke_change(nominal, problem.travel_mm).near_toggle:
        return [nominal]
    try:
        off = optimise(replace(problem, off_toggle=True), pool, name=f"{nominal.name}-off-toggle")
    except DesignError:   # no body off the toggle reaches the range
        return [nominal]
    return [nominal, off.design]


def robust(problem: DesignProblem, nominal: Design, draws: int = DRAWS, seed: int = 0,
           min_yield: float = MIN_YIELD, name: str = "robust", pool=None) -> RobustResult:
    """The robust design of ``problem`` from the nominal answer ``nominal`` (and from the
    answer off the toggle where that one is next to it: :func:`_starts`; ``pool`` runs that
    search, then the searches from the starts side by side); ``met`` says whether the
    written design keeps every chance constraint on its tolerance report and for the
    process (:func:`_process_misses`), and ``why`` not. Raises DesignError if the drawing it
    ends at is itself past the hysteresis law's domain (no datasheet can be written for it)."""
    t0 = time.monotonic()
    jobs = [(problem, start, draws, seed, min_yield, name) for start in _starts(problem, nominal, pool)]
    ends = pool.map(_from_start, jobs) if pool is not None and pool.size > 1 else [_from_start(j) for j in jobs]
    _, d, tol, why = min(ends, key=lambda e: e[0])
    _check_domain(problem, d)
    return RobustResult(d, tol, not why, "; ".join(why), time.monotonic() - t0)


def _from_start(job) -> tuple:
    """The robust search from one start (:func:`robust`'s passes): (rank, written design, its
    tolerance report, the constraints it misses); rank orders ends by whether they miss, by
    how much (:func:`_violation`) and by their parts' median H."""
    problem, start, draws, seed, min_yield, name = job
    with threadpool_limits(1):   # as the nominal search: the answer must not depend on the cores
        return _passes(problem, start, draws, seed, min_yield, name)


def _passes(problem: DesignProblem, start: Design, draws: int, seed: int, min_yield: float, name: str) -> tuple:
    """:func:`_from_start`'s search passes and their written ends (see there)."""
    z_surface = surface_draws(SURFACE_DRAWS)
    best = None
    for k in range(SEARCH_PASSES):
        u0 = np.clip(problem.to_unit(problem.variables(start)), 0, 1)
        u = _search(problem, z_surface, u0, min_yield, SEARCH_BAND - k * PASS_TIGHTENING,
                    SEARCH_STRESS_PROBABILITY - k * PASS_TIGHTENING)
        d = written(problem, problem.design(problem.from_unit(np.clip(u, 0, 1))), name)
        tol = tolerance(d, problem.process, draws, seed, problem.travel_mm, problem.law)
        d, tol, read = _centred(problem, d, tol, draws, seed, name)
        why = _misses(problem, d, tol, min_yield) + _process_misses(problem, d, read)
        rank = (bool(why), max(_violation(problem, tol), _process_violation(problem, read), 0.0),
                tol.hysteresis_fraction_p50)
        if best is None or rank < best[0]:
            best = (rank, d, tol, why)
        if not why:
            break
        start = d
    return best
