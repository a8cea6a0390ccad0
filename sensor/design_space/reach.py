"""The reachable range of a design problem (DESIGN section 13): the smallest and the largest
full-scale force of any feasible body of the problem's family (its body, angle domain, hinge
groups and bounds, stress limit with the search's slack), so that ``dacm design`` says "no body
reaches it" only for a range outside this interval, and names the interval.

Each end is a constrained optimisation of its own, by the same multi-start SLSQP as the design
search (:mod:`sensor.design_space.optimise`): minimise (maximise) log range subject to the
stress utilisation <= 1 - STRESS_SLACK and the angle domain, from a Latin hypercube and from
the corner of every hinge at its lower (upper) bound, at the angles of a coarse grid.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.stats import qmc

from sensor.design_space.optimise import (
    STRESS_SLACK,
    DesignProblem,
    _local_search,
    evaluate,
    feasible,
)

#: Starts per end: Latin-hypercube points, and the grid of angles at the thickness corner.
REACH_STARTS, REACH_GRID = 4, 3


def _end_starts(problem: DesignProblem, corner: float) -> np.ndarray:
    k = problem.n_angles
    lhs = qmc.LatinHypercube(d=len(problem.lower), seed=problem.seed).random(REACH_STARTS)
    axes = [np.linspace(0.1, 0.9, REACH_GRID)] * k
    grid = np.array(np.meshgrid(*axes, indexing="ij")).reshape(k, -1).T
    corners = np.hstack([grid, np.full((len(grid), len(problem.pairs)), corner)])
    return np.vstack([corners, lhs])


def reachable_range(problem: DesignProblem, pool=None, with_bodies: bool = False):
    """(smallest, largest) range (N) of the feasible bodies of the problem's family, within
    the stress limit less STRESS_SLACK: the best feasible body each end's searches found
    (NaN, NaN if none); ``with_bodies``: also the feasible bodies the searches found whose
    range is nearest the problem's (a list, empty if none) and the nearest feasible ranges
    found below and above it. The feasible ranges need not be one interval: the stress limit
    can leave a gap (the basis body in delrin: about 9-20 N), which these name."""
    p = replace(problem, range_N=1.0)     # the range is the objective here, not a constraint
    jobs = [(p, u, "min_range") for u in _end_starts(p, 0.0)] + [(p, u, "max_range") for u in _end_starts(p, 1.0)]
    runs = pool.map(_local_search, jobs) if pool is not None and pool.size > 1 else [_local_search(j) for j in jobs]
    ends = evaluate(p, p.from_unit(np.array([u for u, _, _ in runs])))
    pts = [pt for _, seen, _ in runs for pt in seen] + ends
    good = sorted((pt for pt in pts if feasible(p, pt, slack=STRESS_SLACK - 1e-9, in_range=False)),
                  key=lambda pt: pt.log_range_error)
    reach = (float(np.exp(good[0].log_range_error)), float(np.exp(good[-1].log_range_error))) if good else (np.nan, np.nan)
    if with_bodies:
        # the feasible bodies found nearest the problem's range (starts for a search), and the
        # nearest feasible ranges found below and above it (N; NaN if none)
        target = np.log(problem.range_N)
        near = sorted(good, key=lambda pt: abs(pt.log_range_error - target))
        below = [pt.log_range_error for pt in good if pt.log_range_error <= target]
        above = [pt.log_range_error for pt in good if pt.log_range_error >= target]
        gap = (float(np.exp(max(below))) if below else np.nan, float(np.exp(min(above))) if above else np.nan)
        return reach, [pt.design for pt in near[:REACH_STARTS + REACH_GRID]], gap
    return reach


def unreachable_message(problem: DesignProblem, reach: tuple[float, float]) -> str:
    """The one line for a range outside the reachable interval, naming it."""
    lo, hi = reach
    where = ("no body of the family is feasible at all" if not np.isfinite(lo) else
             f"the reachable interval is {lo:.4g} to {hi:.4g} N")
    return (f"range_N = {problem.range_N:g}: no {problem.body} body within the feasibility rules, "
            f"hinges {problem.hinge_min_mm:g}-{problem.hinge_max_mm:g} mm and the allowable stress "
            f"reaches it at {problem.travel_mm:g} mm travel; {where}")
