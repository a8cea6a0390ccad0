"""The reachable range of a design problem (DESIGN section 13): the smallest and the largest
full-scale force of any feasible body of the problem's family (its body, angle domain, hinge
groups and bounds, stress limit with the search's slack, the hysteresis law's domain), so
that ``dacm design`` says "no body reaches it" only for a range outside this interval, and
names the interval.

Each end is bracketed, then polished. A scan of the feasible angles every REACH_SCAN_STEP_DEG
degrees, with every hinge at its lower bound (the softest bodies) and with equal hinges as
thick as the bounds and the stress limit allow (the stiffest), finds each end's best bodies on
the grid; from the REACH_POLISH best of each and from a Latin hypercube, the same SLSQP as the
design search (:mod:`sensor.design_space.optimise`) minimises (maximises) log range subject
to the stress utilisation <= 1 - STRESS_SLACK, the hysteresis law's domain (H < H_LIMIT) and
the angle domain. The ends are the extremes of every feasible body seen, the scans included,
so they are never inside a feasible body the grid holds (tests/design_space/test_reach.py
holds them against a dense scan of equal-hinge bodies at every thickness; a one-off random
check, stop 57: 30 000 proposed bodies drawn uniformly in the unit box, half of them with
the hinges biased thick, reached 1.56-28.3 N where feasible, inside the reach's 1.029-36.24
N, 1.029-36.54 N on the model since). A family's bodies are found once per process
(:func:`feasible_bodies`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.stats import qmc

from sensor.design_space.optimise import (
    STRESS_SLACK,
    DesignProblem,
    Point,
    _local_search,
    evaluate,
    feasible,
)

#: Angle step of the scans (deg), the best scanned bodies polished per end, the
#: Latin-hypercube starts per end, and the passes that bring the stiffest scan's bodies to
#: the stress limit and the hysteresis law's domain. (Four Latin-hypercube starts found the
#: proposed body's top end at 31.1 N on the model with the input's contact fitted on the
#: plate, below a body of 33.0 N that the family with hinges up to 0.6 mm reaches; eight find
#: 36.2 N, for a quarter more time, 36 -> 44 s, spent only when a range is refused.)
REACH_SCAN_STEP_DEG, REACH_POLISH, REACH_STARTS, LIMIT_PASSES = 1.0, 4, 8, 3


def scan_angles(problem: DesignProblem) -> np.ndarray:
    """The feasible angles on a REACH_SCAN_STEP_DEG grid (rows: phi1 [, phi2], deg)."""
    k = problem.n_angles
    spans = problem.upper[:k] - problem.lower[:k]
    return problem.angle_grid([int(np.ceil(w / REACH_SCAN_STEP_DEG)) + 1 for w in spans])


def softest_scan(problem: DesignProblem, angles: np.ndarray) -> list[Point]:
    """The bodies of ``angles`` with every hinge at its lower bound, as one batch."""
    k = problem.n_angles
    return evaluate(problem, np.hstack([angles, np.tile(problem.lower[k:], (len(angles), 1))]))


def stiffest_scan(problem: DesignProblem, softest: list[Point]) -> list[Point]:
    """At each angle of ``softest``, the body of equal hinges as thick as the bounds, the
    stress limit and the hysteresis law's domain allow. A hinge's bending stress at a given
    travel grows about as its thickness and the strain energy about as its cube, so the
    thickness starts at what both allow from t_min (1 - 2 STRESS_SLACK of each limit), within
    the bounds, and LIMIT_PASSES passes of the same step correct it (a pass that makes a
    body fail is undone)."""
    k = problem.n_angles
    lo, hi = problem.lower[k], problem.upper[k]
    target = np.log1p(-2 * STRESS_SLACK)

    def thickest(logt, pts):  # log t each limit allows, from the bodies pts at log t
        ok = np.array([pt.ok for pt in pts])
        util = np.array([pt.utilisation if pt.ok else 1.0 for pt in pts])
        se = np.array([pt.log_se if pt.ok else 0.0 for pt in pts])
        step = np.minimum(target - np.log(util), (problem.log_se_limit + target - se) / 3.0)
        return ok, np.clip(logt + step, lo, hi)

    ok, logt = thickest(np.full(len(softest), lo), softest)
    logt = np.where(ok, logt, hi)
    Z = np.hstack([np.array([pt.z[:k] for pt in softest]), np.repeat(logt[:, None], len(problem.pairs), axis=1)])
    pts = evaluate(problem, Z)
    for _ in range(LIMIT_PASSES):
        ok, new = thickest(Z[:, k], pts)
        move = ok & (np.abs(new - Z[:, k]) > 1e-4)
        if not move.any():
            break
        Z2 = Z[move].copy()
        Z2[:, k:] = new[move, None]
        for n, z, pt in zip(np.flatnonzero(move), Z2, evaluate(problem, Z2)):
            if pt.ok:
                Z[n], pts[n] = z, pt
    return pts


def _end_starts(problem: DesignProblem, corner: float, scan: list[Point]) -> np.ndarray:
    """Starts in the unit box for one end: the REACH_POLISH feasible scanned bodies of the
    smallest (``corner`` 0, the softest scan) or largest (1, the stiffest) range, and a Latin
    hypercube."""
    good = sorted((pt for pt in scan if feasible(problem, pt, slack=STRESS_SLACK, in_range=False)),
                  key=lambda pt: pt.log_range_error * (1 if corner == 0.0 else -1))
    best = [problem.to_unit(pt.z) for pt in good[:REACH_POLISH]]
    lhs = qmc.LatinHypercube(d=len(problem.lower), seed=problem.seed).random(REACH_STARTS)
    return np.vstack([*best, lhs])


#: The feasible bodies found per problem family (the problem with its range aside, by its
#: repr) in this process, the last REACH_CACHED families: ``optimise`` asks for a family's
#: reach at every range outside it, and a script designing several ranges asks again. The
#: model's constants (root rule, Kt, materials' tables) are taken as fixed in a process.
REACH_CACHED = 8
_found: dict[str, tuple[Point, ...]] = {}


def feasible_bodies(problem: DesignProblem, pool=None) -> tuple[Point, ...]:
    """Every feasible body of the problem's family (its range aside) that the reach's scans
    and end searches find, within the stress limit less STRESS_SLACK and the hysteresis law's
    domain, by increasing range; computed once per family in a process (kept for the last
    REACH_CACHED families; the searches are deterministic: the same family gives the same
    bodies, in a pool or not)."""
    p = replace(problem, range_N=1.0)     # the range is the objective here, not a constraint
    key = repr(p)
    if key not in _found:
        softest = softest_scan(p, scan_angles(p))
        scans = {0.0: softest, 1.0: stiffest_scan(p, softest)}
        jobs = [(p, u, objective) for corner, objective in ((0.0, "min_range"), (1.0, "max_range"))
                for u in _end_starts(p, corner, scans[corner])]
        runs = pool.map(_local_search, jobs) if pool is not None and pool.size > 1 else [_local_search(j) for j in jobs]
        ends = evaluate(p, p.from_unit(np.array([u for u, _, _ in runs])))
        pts = [pt for _, seen, _ in runs for pt in seen] + ends + scans[0.0] + scans[1.0]
        if len(_found) >= REACH_CACHED:
            _found.pop(next(iter(_found)))
        _found[key] = tuple(sorted((pt for pt in pts if feasible(p, pt, slack=STRESS_SLACK - 1e-9, in_range=False)),
                                   key=lambda pt: pt.log_range_error))
    return _found[key]


def reachable_range(problem: DesignProblem, pool=None, with_bodies: bool = False):
    """(smallest, largest) range (N) of the feasible bodies of the problem's family
    (:func:`feasible_bodies`): the best feasible body each end's searches found (NaN, NaN if
    none); ``with_bodies``: also the feasible bodies found whose range is nearest the
    problem's (a list, empty if none) and the nearest feasible ranges found below and above
    it. The feasible ranges need not be one interval: the stress limit can leave a gap (the
    basis body in delrin: about 9-20 N), which these name."""
    good = feasible_bodies(problem, pool)
    reach = (float(np.exp(good[0].log_range_error)), float(np.exp(good[-1].log_range_error))) if good else (np.nan, np.nan)
    if with_bodies:
        # the feasible bodies found nearest the problem's range (starts for a search), and the
        # nearest feasible ranges found below and above it (N; NaN if none)
        target = np.log(problem.range_N)
        near = sorted(good, key=lambda pt: abs(pt.log_range_error - target))
        below = [pt.log_range_error for pt in good if pt.log_range_error <= target]
        above = [pt.log_range_error for pt in good if pt.log_range_error >= target]
        gap = (float(np.exp(max(below))) if below else np.nan, float(np.exp(min(above))) if above else np.nan)
        return reach, [pt.design for pt in near[:REACH_POLISH + REACH_STARTS]], gap
    return reach


def unreachable_message(problem: DesignProblem, reach: tuple[float, float]) -> str:
    """The one line for a range outside the reachable interval, naming it."""
    lo, hi = reach
    where = ("no body of the family is feasible at all" if not np.isfinite(lo) else
             f"the reachable interval is {lo:.4g} to {hi:.4g} N")
    return (f"range_N = {problem.range_N:g}: no {problem.body} body within the feasibility rules, "
            f"hinges {problem.hinge_min_mm:g}-{problem.hinge_max_mm:g} mm, {problem.limits} "
            f"reaches it at {problem.travel_mm:g} mm travel; {where}")
