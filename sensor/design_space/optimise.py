"""Range-targeted design (DESIGN section 13): the body of a given force range with the lowest
predicted hysteresis, within every feasibility rule, the hinge bounds, the allowable stress and
the hysteresis law's domain (H < :data:`~sensor.mechanics.hysteresis.H_LIMIT`).

Variables: phi1, phi2 (the proposed body; phi1 alone for the basis) and the log in-plane
thickness of each group of hinges sharing one thickness (default the mirror-symmetric pairs of
Figure 48: (1, 8), (2, 7), (3, 6), (4, 5), (9, 12), (10, 11); the basis body the first four),
scaled to the unit box.

Method: multi-start SLSQP (:func:`scipy.optimize.minimize`, method "SLSQP") on

    minimise log SE  (H = h SE, the strain-energy law of section 6.2.5)
    subject to  log(range / N) = 0                     (range: input force at the travel)
                utilisation <= 1 - STRESS_SLACK         (peak hinge stress / allowable)
                phi2 <= phi2 edge of the feasible angles (:class:`AngleDomain`)
                H < H_LIMIT                             (the answer's; SE is minimised)
                off the toggle (``off_toggle`` only)     (:mod:`sensor.mechanics.toggle`)
                hinge_min <= t <= hinge_max             (bounds)

with forward-difference gradients whose perturbed bodies are solved together in one batch
(:func:`sensor.mechanics.solver.solve_batch`). Starts: a Latin hypercube over the variables
(seeded), plus the best equal-hinge body of the range on a grid of angles (so the answer is
never worse than an equal-hinge cell), each first scaled to the range by thickening or thinning
every hinge together. The answer: the best converged candidates projected onto their active
hinge bounds, matched to the range again with the free hinges, written values rounded inward
(angles 0.01 deg, hinges 0.1 um) and checked again as written (:func:`accept`). Where no start
ends feasible, or every start scaled to the range lies past the hinge bounds (the search is
then skipped), the reachable interval (:mod:`sensor.design_space.reach`) decides: outside it
the range is refused, naming it; inside it the search starts again from its bodies.

With ``off_toggle`` every body must also stay off the toggle
(:attr:`~sensor.mechanics.toggle.StrokeChange.near_toggle` false), where the beam model's
full-scale numbers have met the continuum: phi2 at least :data:`OFF_TOGGLE_PHI2_DEG` (a
bound), k_out growing at most 2.2 x and A falling to no less than 0.8 x over the stroke (two
more inequality rows, each body's linear limit solved in the same batch: about 5 % more time
a body); its reachable interval is that of the bodies off the toggle.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize
from scipy.stats import qmc
from threadpoolctl import threadpool_limits

from geometry.checks import check_design, phi1_limit_deg
from geometry.errors import GeometryError
from geometry.params import Design, design_from_dict, design_to_dict
from geometry.process import WATER_JET, Process
from geometry.topology import build_beam_model
from sensor.errors import DesignError, SolverError
from sensor.mechanics.hysteresis import DEFAULT_LAW, H_LIMIT, StrainEnergyLaw
from sensor.mechanics.qualifiers import qualify
from sensor.mechanics.solver import SolverOptions, solve_batch
from sensor.mechanics.stress import hinge_stresses, stress_check
from sensor.validation import Number

#: Default thickest hinge, as a fraction of the link width (0.8 mm of 2): a hinge is a neck of
#: its link. Thicker necks' roots poke out of the bodies they join: the cut profile leaves the
#: footprint by up to 0.06 mm at 1.0 mm and 0.1 mm at 0.9 mm, never at 0.8 mm (phi1 3.7-32.8
#: deg, phi2 5-20 deg and the basis body), which geometry.checks does not see.
HINGE_MAX_PER_LINK = 0.4
#: Mirror-symmetric hinge pairs of Figure 48 (hinge numbers; DESIGN section 3).
PAIRS = ((1, 8), (2, 7), (3, 6), (4, 5), (9, 12), (10, 11))
BASIS_PAIRS = PAIRS[:4]


def used_pairs(design: Design) -> tuple[tuple[int, int], ...]:
    """The mirror pairs of ``design``'s used hinges (:data:`PAIRS`, left-hand hinge first)."""
    return tuple(g for g in PAIRS if g[0] in design.used_hinges)


#: The answer's range is the target within RANGE_TOLERANCE (the contract is 1 %; the
#: search matches it to 1e-6 and the written, rounded values move it by about 1e-4).
RANGE_TOLERANCE = 0.01
#: The search keeps the stress utilisation at most 1 - STRESS_SLACK, so the rounding of the
#: written values (0.1 um on a hinge: under 0.1 % of stress) cannot push it over 1.
STRESS_SLACK = 0.005
#: Quanta of the written values: angles (deg) and hinge thicknesses (mm).
ANGLE_QUANTUM, THICKNESS_QUANTUM = 0.01, 1e-4
#: Angle bounds (deg): phi1 from PHI1_MIN up to the side links' limit, phi2 over PHI2_BOUNDS,
#: both cut to the feasible angles by :class:`AngleDomain`.
PHI1_MIN, PHI2_BOUNDS = 2.0, (2.0, 60.0)
#: Forward-difference step in the unit box (the solves are converged to 1e-9: the FD
#: gradients agree with central differences of step 1e-8 to 1e-5 relative), SLSQP's limits,
#: and the objective's scale: SLSQP's first step is the objective's gradient in the unit box
#: (its first Hessian is the identity), of order 1-5 unscaled, which leaves the region where
#: the range constraint's linearisation holds; scaled, the first step is a few % of the box.
FD_STEP = 1e-6
SLSQP_ITERATIONS, SLSQP_FTOL, OBJECTIVE_SCALE = 100, 1e-8, 0.03
#: Latin-hypercube starts of the search, and finalists carried to the acceptance.
STARTS, FINALISTS = 12, 6
#: A failed solve's objective/constraint values (far from feasible, finite for SLSQP).
FAILED = 10.0
#: With ``off_toggle``, the least phi2 (deg): a degree above the flag's
#: :data:`~sensor.mechanics.toggle.PHI2_LIMIT_DEG`. The search ends on it, and the beam
#: model's error at 1 mm grows as phi2 falls (the continuum table's DACMs of phi2 11.06 to
#: 11.53 deg met both targets with up to +2.30 % on k_out and +1.47 % on A).
OFF_TOGGLE_PHI2_DEG = 12.0
#: The search's rows keep the stroke's log margins to the flag's limits
#: (:attr:`~sensor.mechanics.toggle.StrokeChange.log_margins`) at least this, so that the
#: written values' rounding (0.01 deg moves the k_out ratio by about 0.1 % next to the
#: toggle) cannot put the answer past them.
TOGGLE_ROUNDING = 0.005

_RANGE = Number(0.0, 1e4, lo_open=True, unit="N")
_THICKNESS = Number(0.0, 10.0, lo_open=True, unit="mm")
#: What building or solving a candidate may raise: a geometry the builder refuses, a solve
#: that does not finish. Anything else is a bug and propagates.
MODEL_ERRORS = (GeometryError, SolverError)


@dataclass(frozen=True)
class DesignProblem:
    """A range-targeted design problem (mm, N). ``body``: "proposed" or "basis";
    ``pairs``: the hinge groups that share one thickness (default the mirror pairs; one
    group of every hinge gives equal hinges); ``base``: other Design fields; ``process``:
    the cutting process, whose ``min_drawn_hinge_mm`` is the default ``hinge_min_mm``;
    ``hinge_max_mm`` defaults to the link width (a hinge is a neck of its link);
    ``off_toggle``: every DACM must stay off the toggle (module docstring; the basis body has
    none)."""

    range_N: float
    travel_mm: float = 1.0
    body: str = "proposed"
    hinge_min_mm: float | None = None
    hinge_max_mm: float | None = None
    pairs: tuple[tuple[int, ...], ...] | None = None
    seed: int = 0
    base: dict = field(default_factory=dict)
    process: Process = WATER_JET
    law: StrainEnergyLaw = DEFAULT_LAW
    off_toggle: bool = False

    def __post_init__(self):
        _RANGE.check("range_N", self.range_N, DesignError)
        if self.body not in ("proposed", "basis"):
            raise DesignError(f"body = {self.body!r}: must be 'proposed' or 'basis'")
        if self.off_toggle and self.body == "basis":
            raise DesignError("off_toggle = True: the basis body has no toggle (it has no middle branch)")
        ref = self.reference
        Number(0.0, ref.height_mm, lo_open=True, unit="mm, at most the body's height").check(
            "travel_mm", self.travel_mm, DesignError)
        if not self.travel_mm < ref.fiber_clearance_mm:
            raise DesignError(f"travel_mm = {self.travel_mm:g}: must be below fiber_clearance_mm = "
                              f"{ref.fiber_clearance_mm:g} mm (the mirror must not touch the fiber)")
        if self.hinge_min_mm is None:
            object.__setattr__(self, "hinge_min_mm", self.process.min_drawn_hinge_mm)
        if self.hinge_max_mm is None:
            object.__setattr__(self, "hinge_max_mm", HINGE_MAX_PER_LINK * ref.link_width_mm)
        for name in ("hinge_min_mm", "hinge_max_mm"):
            _THICKNESS.check(name, getattr(self, name), DesignError)
        if self.hinge_min_mm < ref.min_feature_mm:
            raise DesignError(f"hinge_min_mm = {self.hinge_min_mm:g}: must be >= min_feature_mm = "
                              f"{ref.min_feature_mm:g} mm (what the cutting process can hold)")
        if not self.hinge_max_mm > self.hinge_min_mm:
            raise DesignError(f"hinge_max_mm = {self.hinge_max_mm:g}: must exceed hinge_min_mm = "
                              f"{self.hinge_min_mm:g} mm")
        Number(0, 2**32 - 1, integer=True).check("seed", self.seed, DesignError)
        if self.pairs is None:
            object.__setattr__(self, "pairs", BASIS_PAIRS if self.body == "basis" else PAIRS)
        used = ref.used_hinges
        if sorted(h for g in self.pairs for h in g) != list(used):
            raise DesignError(f"pairs = {self.pairs!r}: must group each used hinge "
                              f"({min(used)}-{max(used)}) exactly once")

    @functools.cached_property
    def reference(self) -> Design:
        """The base design (angles and hinges to be chosen), built once."""
        base = {k: v for k, v in self.base.items() if k not in ("phi1_deg", "phi2_deg", "hinge_set",
                                                                "hinge_thickness_mm", "name", "body")}
        return design_from_dict({**base, "phi1_deg": 20.0, "phi2_deg": None if self.body == "basis" else 30.0,
                                 "hinge_set": "optimised", "hinge_thickness_mm": [0.5] * 12}, source="design base")

    @property
    def limits(self) -> str:
        """The limits besides the rules and the hinges, as the refusals name them."""
        return f"the allowable stress, H < {H_LIMIT:g} and off the toggle" if self.off_toggle else \
            f"the allowable stress and H < {H_LIMIT:g}"

    @property
    def n_angles(self) -> int:
        return 1 if self.body == "basis" else 2

    @property
    def log_se_limit(self) -> float:
        """log of the strain energy (mJ) past which the hysteresis law leaves its domain
        (:attr:`StrainEnergyLaw.max_strain_energy_mJ`; inf without hysteresis)."""
        return math.log(self.law.max_strain_energy_mJ)

    def within_law(self, log_se: float) -> bool:
        """Whether a body of strain energy exp(``log_se``) mJ is inside the hysteresis law's
        domain (H below :data:`~sensor.mechanics.hysteresis.H_LIMIT`)."""
        return log_se < self.log_se_limit

    @functools.cached_property
    def domain(self) -> "AngleDomain":
        return AngleDomain.of(self)

    @functools.cached_property
    def lower(self) -> np.ndarray:
        """Lower bounds of the variables: angles (deg), then log thickness (log mm)."""
        return np.array(self.domain.lower + [math.log(self.hinge_min_mm)] * len(self.pairs))

    @functools.cached_property
    def upper(self) -> np.ndarray:
        return np.array(self.domain.upper + [math.log(self.hinge_max_mm)] * len(self.pairs))

    def to_unit(self, z) -> np.ndarray:
        return (np.asarray(z, dtype=float) - self.lower) / (self.upper - self.lower)

    def from_unit(self, u) -> np.ndarray:
        return self.lower + np.asarray(u, dtype=float) * (self.upper - self.lower)

    def angle_grid(self, counts) -> np.ndarray:
        """The angles (rows: phi1 [, phi2], deg) of a grid of ``counts[i]`` points along each
        angle's bounds, those beyond the domain's phi2 edge left out."""
        k = self.n_angles
        axes = [np.linspace(a, b, n) for a, b, n in zip(self.lower[:k], self.upper[:k], counts)]
        angles = np.array(np.meshgrid(*axes, indexing="ij")).reshape(k, -1).T
        if self.body == "proposed":
            angles = angles[angles[:, 1] <= [self.domain.phi2_edge(p) for p in angles[:, 0]]]
        return angles

    def design(self, z, name: str = "optimised") -> Design:
        """The design of variables ``z`` (angles in deg, then log thickness of each group)."""
        ref = self.reference
        t = list(ref.hinge_thickness_mm)
        for group, lt in zip(self.pairs, z[self.n_angles:]):
            for h in group:
                t[h - 1] = float(math.exp(lt))
        return ref.replace(phi1_deg=float(z[0]), phi2_deg=None if self.body == "basis" else float(z[1]),
                           hinge_thickness_mm=tuple(t), name=name)

    def variables(self, design: Design) -> np.ndarray:
        """The variables of a design (the first hinge of each group gives its thickness)."""
        angles = [design.phi1_deg] + ([] if self.body == "basis" else [design.phi2_deg])
        return np.array(angles + [math.log(design.hinge_thickness_mm[g[0] - 1]) for g in self.pairs])


@dataclass(frozen=True)
class AngleDomain:
    """The feasible angles (deg) of a problem's body with every hinge at ``hinge_max_mm``
    (thinner hinges only widen the gaps): phi1 in [lower[0], upper[0]]; for the proposed body
    phi2 in [PHI2_BOUNDS[0] (:data:`OFF_TOGGLE_PHI2_DEG` for an ``off_toggle`` problem),
    ``phi2_edge(phi1)``], the edge found by bisection on
    :func:`geometry.checks.check_design` at every degree of phi1 and interpolated linearly
    (0.05 deg inside the found edge)."""

    lower: list
    upper: list
    phi1_grid: tuple = ()
    phi2_edges: tuple = ()

    @classmethod
    def of(cls, problem: DesignProblem) -> "AngleDomain":
        ref = problem.reference.replace(hinge_thickness_mm=(problem.hinge_max_mm,) * 12)
        hi1 = phi1_limit_deg(ref) - 0.05
        phi2_lo = OFF_TOGGLE_PHI2_DEG if problem.off_toggle else PHI2_BOUNDS[0]

        def ok(p1, p2=None):
            return check_design(ref.replace(phi1_deg=p1, phi2_deg=p2)).feasible

        probe = None if problem.body == "basis" else phi2_lo
        lo1 = _bisect(lambda p1: ok(p1, probe), PHI1_MIN, hi1, feasible_high=True) + 0.05
        if problem.body == "basis":
            return cls([lo1], [hi1])
        grid = tuple(np.linspace(lo1, hi1, max(2, int(math.ceil(hi1 - lo1)) + 1)))
        edges = tuple(_bisect(lambda p2: ok(p1, p2), phi2_lo, PHI2_BOUNDS[1], feasible_high=False) - 0.05
                      for p1 in grid)
        return cls([lo1, phi2_lo], [hi1, max(edges)], grid, edges)

    def phi2_edge(self, phi1) -> float:
        return float(np.interp(phi1, self.phi1_grid, self.phi2_edges))


def _bisect(feasible, a: float, b: float, feasible_high: bool, steps: int = 12) -> float:
    """The edge (to (b - a) / 2^steps) between the infeasible and feasible part of [a, b]:
    feasible above it (``feasible_high``) or below it; an end if the interval is all one."""
    if feasible(a) == feasible(b):
        return a if feasible_high else b
    for _ in range(steps):
        m = 0.5 * (a + b)
        if feasible(m) == feasible_high:
            b = m
        else:
            a = m
    return b if feasible_high else a


# --- evaluation -----------------------------------------------------------------------------

@dataclass(frozen=True)
class Point:
    """One evaluated body: its variables, design, log range error, log strain energy, each
    used hinge's stress utilisation (peak / allowable; FAILED for a failed solve) and the
    phi2 margin to the angle domain's edge (deg; inf for the basis) and, for an
    ``off_toggle`` problem, the log margins to the toggle flag's limits
    (:attr:`~sensor.mechanics.toggle.StrokeChange.log_margins`; -FAILED each where the
    body's linear limit does not solve; empty otherwise)."""

    z: tuple
    design: Design | None
    log_range_error: float = FAILED
    log_se: float = FAILED
    hinge_utilisation: tuple = ()
    phi2_margin: float = 0.0
    toggle_margins: tuple = ()
    reason: str = ""

    @property
    def utilisation(self) -> float:
        """The largest hinge stress utilisation (FAILED for a failed solve)."""
        return max(self.hinge_utilisation) if self.hinge_utilisation else FAILED

    @property
    def ok(self) -> bool:
        return not self.reason

    @property
    def off_toggle(self) -> bool:
        """Whether both toggle margins are >= 0 (false if they were not computed; phi2 is
        held by the bounds)."""
        return bool(self.toggle_margins) and min(self.toggle_margins) >= 0


def solve_designs(designs: list[Design], travel_mm: float):
    """Build and solve designs of one body together: per design (model, result) or
    (None, error message)."""
    models, idx, out = [], [], [None] * len(designs)
    for n, d in enumerate(designs):
        if max(d.used_thickness_mm) > d.link_width_mm:   # a neck wider than its link: no body
            out[n] = (None, f"geometry: a hinge of {max(d.used_thickness_mm):.4g} mm is thicker than the link "
                            f"({d.link_width_mm:g} mm)")
            continue
        try:
            models.append(build_beam_model(d))
            idx.append(n)
        except MODEL_ERRORS as exc:
            out[n] = (None, f"geometry: {' '.join(str(exc).split())[:160]}")
    if models:
        try:
            res, errs = solve_batch(models, target_output_mm=travel_mm, options=SolverOptions())
        except SolverError as exc:
            res, errs = [None] * len(models), [exc] * len(models)
        for n, m, r, e in zip(idx, models, res, errs):
            out[n] = (m, r) if r is not None else (None, f"solver: {e}")
    return out


def evaluate(problem: DesignProblem, Z) -> list[Point]:
    """Evaluate bodies of variables Z (rows), solved together as one batch."""
    Z = np.atleast_2d(np.asarray(Z, dtype=float))
    designs = [problem.design(z) for z in Z]
    solved = solve_designs(designs, problem.travel_mm)
    toggle = _toggle_margins(solved) if problem.off_toggle else {}
    out = []
    for n, (z, d, (m, r)) in enumerate(zip(Z, designs, solved)):
        margin = math.inf if problem.body == "basis" else problem.domain.phi2_edge(z[0]) - z[1]
        if m is None:
            out.append(Point(tuple(z), d, phi2_margin=margin, reason=r))
            continue
        allow = d.material.allowable_stress_MPa
        util = tuple(s.peak_MPa / allow for s in hinge_stresses(m, r).values())
        out.append(Point(tuple(z), d, math.log(r.input_force_N / problem.range_N), math.log(r.strain_energy_mJ),
                         util, margin, toggle.get(n, ())))
    return out


def _toggle_margins(solved) -> dict[int, tuple]:
    """Per body of ``solved`` (:func:`solve_designs`) that solved, by index, its log margins
    to the toggle flag's limits, their linear limits solved as one batch."""
    from sensor.mechanics.toggle import stroke_changes

    idx = [n for n, (m, _) in enumerate(solved) if m is not None]
    changes = stroke_changes([solved[n][0] for n in idx], [solved[n][1] for n in idx], [None] * len(idx))
    return {n: (c.log_margins if c is not None else (-FAILED, -FAILED)) for n, (c, _) in zip(idx, changes)}


def toggle_rows(problem: DesignProblem, pt: Point) -> np.ndarray:
    """The off-toggle constraint rows of a point (>= 0 when met): its log margins to the
    toggle flag's limits less :data:`TOGGLE_ROUNDING` (capped at 1; -FAILED where they could
    not be computed); none unless the problem is ``off_toggle``."""
    if not problem.off_toggle:
        return np.zeros(0)
    return np.minimum(pt.toggle_margins or (-FAILED, -FAILED), 1.0) - TOGGLE_ROUNDING


def toggle_miss(design: Design, model, result) -> str:
    """Why a solved DACM is not off the toggle as ``off_toggle`` asks: phi2 below
    :data:`OFF_TOGGLE_PHI2_DEG` or marked by its stroke ("" if it is off it)."""
    from sensor.mechanics.toggle import stroke_change

    if design.phi2_deg is not None and design.phi2_deg < OFF_TOGGLE_PHI2_DEG - 1e-9:
        return f"phi2 {design.phi2_deg:g} deg is below the {OFF_TOGGLE_PHI2_DEG:g} deg kept off the toggle"
    change = stroke_change(model, result, design.phi2_deg)
    if min(change.log_margins) >= 0:
        return ""
    return (f"next to the toggle (over the stroke k_out grows {change.k_out_ratio:.3f} x, A changes "
            f"{change.amplification_ratio:.3f} x)")


class _Local:
    """The SLSQP functions of one problem in the unit box, cached: a point's values come from
    one solve, its forward-difference gradient (asked for only at accepted iterates) from one
    batch solve of its perturbations; ``points`` keeps every body evaluated and
    ``solves`` counts the solves."""

    def __init__(self, problem: DesignProblem, objective: str = "se"):
        self.p, self.objective = problem, objective
        self.values: dict[bytes, np.ndarray] = {}
        self.grads: dict[bytes, np.ndarray] = {}
        self.points: list[Point] = []
        self.solves = 0

    def _values(self, pt: Point) -> np.ndarray:
        obj = {"se": pt.log_se, "min_range": pt.log_range_error, "max_range": -pt.log_range_error}[self.objective]
        n = len(self.p.reference.used_hinges)
        util = np.array(pt.hinge_utilisation) if pt.hinge_utilisation else np.full(n, FAILED)
        # the range ends' searches keep inside the hysteresis law's domain (with the stress's
        # slack: SLSQP ends on an active constraint); the design search needs no such row: it
        # minimises SE, so a range whose least SE is past the domain has no body in it
        # (feasible() rejects it)
        law = [] if self.objective == "se" else [
            min(self.p.log_se_limit + math.log1p(-STRESS_SLACK) - pt.log_se, 1.0)]
        return np.concatenate([[obj, pt.log_range_error,
                                pt.phi2_margin / 10.0 if math.isfinite(pt.phi2_margin) else 1.0],
                               law, toggle_rows(self.p, pt), math.log1p(-STRESS_SLACK) - np.log(np.maximum(util, 1e-9))])

    def at(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        key = u.tobytes()
        if key not in self.values:
            pt = evaluate(self.p, self.p.from_unit(u)[None])[0]
            self.points.append(pt)
            self.solves += 1
            self.values[key] = self._values(pt)
        return self.values[key]

    def grad(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        key = u.tobytes()
        if key not in self.grads:
            step = np.where(u + FD_STEP <= 1.0, FD_STEP, -FD_STEP)   # backward at the upper bound
            U = u + np.diag(step)
            vals = np.array([self._values(pt) for pt in evaluate(self.p, self.p.from_unit(U))])
            self.solves += len(U)
            self.grads[key] = (vals - self.at(u)).T / step
        return self.grads[key]

    def run(self, u0, equality: bool = True):
        cons = [{"type": "ineq", "fun": lambda u: self.at(u)[2:], "jac": lambda u: self.grad(u)[2:]}]
        if equality:
            cons.append({"type": "eq", "fun": lambda u: self.at(u)[1:2], "jac": lambda u: self.grad(u)[1:2]})
        return minimize(lambda u: OBJECTIVE_SCALE * self.at(u)[0], np.clip(u0, 0, 1),
                        jac=lambda u: OBJECTIVE_SCALE * self.grad(u)[0],
                        method="SLSQP", bounds=[(0.0, 1.0)] * len(u0), constraints=cons,
                        options={"maxiter": SLSQP_ITERATIONS, "ftol": SLSQP_FTOL})


def feasible(problem: DesignProblem, pt: Point, slack: float = 0.0, in_range: bool = True) -> bool:
    """Whether a point keeps the range (within RANGE_TOLERANCE; unless not ``in_range``), the
    stress (with ``slack``), the hysteresis law's domain (H below
    :data:`~sensor.mechanics.hysteresis.H_LIMIT`), the hinge bounds, every rule of
    :func:`geometry.checks.check_design` and, for an ``off_toggle`` problem, stays off the
    toggle."""
    if not pt.ok or pt.utilisation > 1 - slack or (in_range and abs(pt.log_range_error) > math.log1p(RANGE_TOLERANCE)):
        return False
    if problem.off_toggle and not pt.off_toggle:
        return False
    if not problem.within_law(pt.log_se):
        return False
    t = np.array(pt.design.used_thickness_mm)
    if t.min() < problem.hinge_min_mm - 1e-12 or t.max() > problem.hinge_max_mm + 1e-12:
        return False
    return check_design(pt.design).feasible


def _local_search(args) -> tuple[np.ndarray, list[Point], int]:
    """One SLSQP run: (its end in the unit box, every point evaluated, solves made). BLAS
    runs on one thread, as in the pool's workers: with more, its sums are ordered otherwise,
    and SLSQP's iterates (and the answer, by a quantum of the written values) depended on
    where the search ran."""
    problem, u0, objective = args
    with threadpool_limits(1):
        loc = _Local(problem, objective)
        res = loc.run(u0, equality=objective == "se")
    return np.clip(res.x, 0, 1), loc.points, loc.solves


# --- starts ---------------------------------------------------------------------------------

def scale_to_range(problem: DesignProblem, Z, iterations: int = 12, tolerance: float = 1e-6,
                   counter: list | None = None) -> np.ndarray:
    """Variables Z with every hinge thickened or thinned together (one common factor per row)
    until the range is the target (range ~ t^3 at fixed shape: a secant in log-log), not
    clipped to the hinge bounds. A row that fails to solve is returned as it came.
    ``counter``: a one-element list the number of solves is added to."""
    Z = np.array(np.atleast_2d(Z), dtype=float)
    prev: list = [None] * len(Z)
    alive = np.arange(len(Z))
    for _ in range(iterations):
        if not len(alive):
            break
        pts = evaluate(problem, Z[alive])
        if counter is not None:
            counter[0] += len(alive)
        keep = []
        for k, pt in zip(alive, pts):
            err = pt.log_range_error
            if not pt.ok or abs(err) <= tolerance:
                continue
            shift = 0.0
            slope = 3.0 if prev[k] is None or prev[k][0] == 0 else (err - prev[k][1]) / prev[k][0]
            slope = min(max(slope, 1.0), 5.0)
            shift = -err / slope
            prev[k] = (shift, err)
            Z[k, problem.n_angles:] += shift
            keep.append(k)
        alive = np.array(keep, dtype=int)
    return Z


def equal_hinge_start(problem: DesignProblem, n: int = 8, counter: list | None = None) -> np.ndarray | None:
    """The best feasible equal-hinge body of the range on an n x n grid of angles (n for the
    basis body), as variables; None if no cell of the grid is feasible."""
    angles = problem.angle_grid([n] * problem.n_angles)
    t0 = math.log(math.sqrt(problem.hinge_min_mm * problem.hinge_max_mm))
    Z = scale_to_range(problem, np.hstack([angles, np.full((len(angles), len(problem.pairs)), t0)]),
                       counter=counter)
    pts = evaluate(problem, Z)
    good = [pt for pt in pts if feasible(problem, pt)]
    return np.array(min(good, key=lambda pt: pt.log_se).z) if good else None


def starts(problem: DesignProblem, n: int = STARTS, counter: list | None = None) -> np.ndarray:
    """Start points as variables, not clipped to the bounds: a Latin hypercube of n (seeded by
    ``problem.seed``) scaled to the range, and the best equal-hinge body of the range."""
    lhs = qmc.LatinHypercube(d=len(problem.lower), seed=problem.seed).random(n)
    Z = scale_to_range(problem, problem.from_unit(lhs), counter=counter)
    eq = equal_hinge_start(problem, counter=counter)
    return Z if eq is None else np.vstack([eq, Z])


def beyond_bounds(problem: DesignProblem, Z, counter: list | None = None) -> bool:
    """Whether no start ``Z`` (variables, scaled to the range) is a body the search can begin
    from inside the bounds: every one either has all its hinges past the same bound (thicker
    than hinge_max or thinner than hinge_min: the range lies beyond what its shape reaches
    within them, range growing with every hinge) or does not solve. ``counter``: as
    :func:`scale_to_range`'s."""
    Z = np.atleast_2d(Z)
    k = problem.n_angles
    inside = ~((Z[:, k:] > problem.upper[k:]).all(axis=1) | (Z[:, k:] < problem.lower[k:]).all(axis=1))
    if not inside.any():
        return True
    if counter is not None:
        counter[0] += int(inside.sum())
    return not any(pt.ok for pt in evaluate(problem, Z[inside]))


# --- the answer -----------------------------------------------------------------------------

def _round_inward(v: float, lo: float, hi: float, q: float) -> float:
    """v rounded to the quantum q, moved inside [lo, hi] by whole quanta if it left it."""
    r = round(v / q) * q
    if r > hi:
        r = math.floor(hi / q + 1e-9) * q
    if r < lo:
        r = math.ceil(lo / q - 1e-9) * q
    return float(round(r, 10))


def written(problem: DesignProblem, design: Design, name: str) -> Design:
    """The design as it is written: angles to ANGLE_QUANTUM, hinges to THICKNESS_QUANTUM,
    each rounded inward (inside the angle domain and the hinge bounds), and read back
    through the TOML writer and reader."""
    import tomllib

    import tomli_w

    p1 = _round_inward(design.phi1_deg, problem.lower[0], problem.upper[0], ANGLE_QUANTUM)
    p2 = None if design.is_basis else _round_inward(design.phi2_deg, problem.lower[1],
                                                    problem.domain.phi2_edge(p1), ANGLE_QUANTUM)
    n = len(design.used_hinges)
    t = tuple(_round_inward(v, problem.hinge_min_mm, problem.hinge_max_mm, THICKNESS_QUANTUM)
              for v in design.used_thickness_mm) + design.hinge_thickness_mm[n:]
    d = design.replace(phi1_deg=p1, phi2_deg=p2, hinge_thickness_mm=t, name=name)
    return design_from_dict(tomllib.loads(tomli_w.dumps({"design": design_to_dict(d)}))["design"])


#: :func:`project`: the least d log(range) / d log(t) of the unsnapped hinges that carries
#: the range back (every hinge together gives about 3, range ~ t^3; a group under a tenth of
#: that would need steps ten times the range error), and the largest Newton step in log t.
PROJECT_MIN_SLOPE = 0.3
PROJECT_MAX_STEP = 0.1


def project(problem: DesignProblem, z, atol: float = 1e-3) -> np.ndarray | None:
    """Variables z snapped onto the hinge bounds they are within ``atol`` (in log t) of, the
    other hinges scaled together to bring the range back to the target (all hinges if every
    one is at a bound, or if the others raise the range less than :data:`PROJECT_MIN_SLOPE`:
    a group can barely move the range, or even lower it, where its bending and its
    centroid's axial coupling balance; the snapped hinges then leave their bounds, inwards
    or not at all); None when that cannot be done inside the bounds. Newton steps on the
    common log factor, each at most :data:`PROJECT_MAX_STEP`."""
    z = np.array(z, dtype=float)
    k = problem.n_angles
    lo, hi = problem.lower[k:], problem.upper[k:]
    t = np.clip(z[k:], lo, hi)
    t = np.where(t - lo < atol, lo, np.where(hi - t < atol, hi, t))
    free = (t > lo) & (t < hi)
    if not free.any():
        free[:] = True
    z[k:] = t
    for _ in range(12):
        pt = evaluate(problem, z[None])[0]
        if not pt.ok:
            return None
        err = pt.log_range_error
        if abs(err) <= 1e-7:
            break
        # a Newton step on the free groups' common log factor (forward-difference slope)
        h = -1e-5                         # thinning: never past the upper bound
        z2 = z.copy()
        z2[k:][free] += h
        probe = evaluate(problem, z2[None])[0]
        if not probe.ok:
            return None
        slope = (probe.log_range_error - err) / h
        if not slope > PROJECT_MIN_SLOPE and not free.all():
            free[:] = True
            continue
        if not slope > 0:
            return None
        z[k:][free] -= np.clip(err / slope, -PROJECT_MAX_STEP, PROJECT_MAX_STEP)
    zt = z[k:]
    if (zt < lo - 1e-12).any() or (zt > hi + 1e-12).any():
        return None
    return z


def accept(problem: DesignProblem, design: Design) -> tuple[bool, str]:
    """The final check of a written design: it solves, its range is the target within
    RANGE_TOLERANCE, its stress utilisation is at most 1, its predicted hysteresis is inside
    the law's domain (below H_LIMIT), its hinges are inside the bounds, it keeps every
    feasibility rule and, for an ``off_toggle`` problem, it is not next to the toggle.
    (ok, why not)."""
    m, r = solve_designs([design], problem.travel_mm)[0]
    if m is None:
        return False, r
    err = r.input_force_N / problem.range_N - 1
    if abs(err) > RANGE_TOLERANCE:
        return False, f"range {r.input_force_N:.4g} N is {100 * err:+.2f} % off"
    util = stress_check(design, m, r).utilisation
    if util > 1:
        return False, f"stress {util:.4f} x allowable"
    if not problem.within_law(math.log(r.strain_energy_mJ)):
        h = qualify(r, problem.law).hysteresis
        return False, f"predicted hysteresis {h:.4f}: past the hysteresis law's domain (H < {H_LIMIT:g})"
    t = np.array(design.used_thickness_mm)
    if t.min() < problem.hinge_min_mm - 1e-12 or t.max() > problem.hinge_max_mm + 1e-12:
        return False, f"hinges {t.min():.4f}-{t.max():.4f} mm outside {problem.hinge_min_mm:g}-{problem.hinge_max_mm:g}"
    if problem.off_toggle and (why := toggle_miss(design, m, r)):
        return False, why
    fail = check_design(design).first_failure
    if fail is not None:
        return False, f"{fail.rule}: {fail.message}"
    return _profile_inside(design)


def _profile_inside(design: Design) -> tuple[bool, str]:
    """Whether the cut profile (the CAD face, roots included) stays in the footprint: the
    feasibility rules check the parts with the hinges cut back to their flexible length."""
    from geometry.cad import profile_face

    bb = profile_face(design).BoundingBox()
    tol = 1e-6
    if (bb.xmin < -design.width_mm / 2 - tol or bb.xmax > design.width_mm / 2 + tol
            or bb.ymin < -tol or bb.ymax > design.height_mm + tol):
        return False, (f"profile spans x [{bb.xmin:.2f}, {bb.xmax:.2f}], y [{bb.ymin:.2f}, {bb.ymax:.2f}] mm: "
                       f"outside the footprint {design.width_mm:g} x {design.height_mm:g} mm")
    return True, ""


@dataclass(frozen=True)
class DesignResult:
    """The optimiser's answer: the written design, its hysteresis and stress utilisation, the
    reachable interval (N; NaN unless the search needed it), the solves of the search (starts
    and SLSQP; the acceptance's few are not counted) and its wall time (s)."""

    design: Design
    problem: DesignProblem
    hysteresis: float
    utilisation: float
    reach: tuple[float, float]
    evaluations: int
    seconds: float


def optimise(problem: DesignProblem, pool=None, n_starts: int = STARTS, name: str = "optimised") -> DesignResult:
    """The best body of the problem's range (module docstring); ``pool`` a
    :class:`~sensor.design_space.execution.TaskPool` for the local searches (default: in this
    process). When no start reaches a feasible body, or every start scaled to the range lies
    past the hinge bounds (:func:`beyond_bounds`: the search from them is skipped), the
    reachable interval is computed (:func:`sensor.design_space.reach.reachable_range`):
    outside it, :class:`DesignError` names it; inside it, the search starts again from the
    feasible bodies the reach computation found nearest the range."""
    from sensor.design_space.reach import reachable_range, unreachable_message

    t0 = time.monotonic()
    counter = [0]
    Z0 = starts(problem, n_starts, counter)
    best, evaluations, rejected = None, 0, []
    if not beyond_bounds(problem, Z0, counter):  # else the reach decides first (it searches if inside)
        best, evaluations, rejected = _search(problem, np.clip(problem.to_unit(Z0), 0, 1), pool, name)
    reach = (math.nan, math.nan)
    if best is None:
        reach, ends, gap = reachable_range(problem, pool, with_bodies=True)
        if not reach[0] * (1 - RANGE_TOLERANCE) <= problem.range_N <= reach[1] * (1 + RANGE_TOLERANCE):
            raise DesignError(unreachable_message(problem, reach))
        more = scale_to_range(problem, np.array([problem.variables(d) for d in ends]), counter=counter)
        best, extra, rejected_near = _search(problem, np.clip(problem.to_unit(more), 0, 1), pool, name)
        rejected = rejected_near or rejected
        evaluations += extra
        if best is None:
            why = (f"the bodies found at the range fail the written design's check ({rejected[0]})" if rejected
                   else f"the nearest found are at {gap[0]:.4g} and {gap[1]:.4g} N (the limits leave a gap)")
            raise DesignError(f"range_N = {problem.range_N:g}: no {problem.body} body found within the feasibility "
                              f"rules, hinges {problem.hinge_min_mm:g}-{problem.hinge_max_mm:g} mm, {problem.limits}; "
                              f"feasible bodies reach {reach[0]:.4g} to {reach[1]:.4g} N, "
                              f"but {why}")
    h, util, design = best
    return DesignResult(design, problem, h, util, reach, evaluations + counter[0], time.monotonic() - t0)


def _search(problem: DesignProblem, U0: np.ndarray, pool, name: str):
    """SLSQP from each start; the best of up to FINALISTS feasible candidates, each projected
    and written (:func:`project`, :func:`written`, :func:`accept`): ((H, utilisation,
    design) or None, bodies evaluated, why :func:`accept` rejected the written ones)."""
    jobs = [(problem, u, "se") for u in U0]
    runs = pool.map(_local_search, jobs) if pool is not None and pool.size > 1 else [_local_search(j) for j in jobs]
    evaluations = sum(n for _, _, n in runs)
    ends = evaluate(problem, problem.from_unit(np.array([u for u, _, _ in runs])))
    seen = [pt for _, pts, _ in runs for pt in pts] + ends
    candidates = sorted((pt for pt in seen if feasible(problem, pt)), key=lambda pt: pt.log_se)
    # ends just over the stress limit or off the range are projected too
    candidates += sorted((pt for pt in ends if pt.ok and pt.utilisation <= 1.01), key=lambda pt: pt.log_se)
    finals, rejected = [], []
    for pt in candidates[:4 * FINALISTS]:
        z = project(problem, pt.z)
        if z is None:
            continue
        d = written(problem, problem.design(z), name)
        if any(d == f for f in finals):
            continue
        ok, why = accept(problem, d)
        if ok:
            finals.append(d)
        else:
            rejected.append(why)
        if len(finals) == FINALISTS:
            break
    if not finals:
        return None, evaluations, rejected
    scored = [(qualify(r, problem.law).hysteresis, stress_check(d, m, r).utilisation, d)
              for d, (m, r) in zip(finals, solve_designs(finals, problem.travel_mm))]
    return min(scored, key=lambda s: s[0]), evaluations, rejected


def describe(design: Design, problem: DesignProblem) -> dict:
    """The numbers of a design at the problem's travel, from a fresh solve (the datasheet's
    resolution from the full sensor model): the keys of ``dacm design --json``."""
    from dataclasses import asdict

    from sensor.mechanics.toggle import stroke_change
    from sensor.readout.datasheet import datasheet
    from sensor.readout.sensor_model import build_sensor

    m, r = solve_designs([design], problem.travel_mm)[0]
    if m is None:
        raise DesignError(f"design {design.name}: does not solve to the travel {problem.travel_mm:g} mm ({r})")
    q = qualify(r, problem.law)
    sheet = datasheet(build_sensor(design, law=problem.law, target_output_mm=problem.travel_mm),
                      material=design.material.name)
    return {"design": design_to_dict(design), "range_N": q.range_N, "hysteresis": q.hysteresis,
            "resolution_N": sheet.resolution_N, "amplification": q.amplification,
            "k_out_N_per_mm": q.k_out_N_per_mm, "strain_energy_mJ": q.strain_energy_mJ,
            "stress_utilisation": stress_check(design, m, r).utilisation,
            "quality_mm_per_N": q.quality_mm_per_N, **stroke_change(m, r, design.phi2_deg).to_dict(),
            "datasheet": asdict(sheet)}
