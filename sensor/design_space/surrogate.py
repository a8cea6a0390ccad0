"""The parts cut from one drawing, by a response surface in the hinges' deviates (DESIGN
section 16): what the robust search (:mod:`sensor.design_space.robust`) reads instead of
solving every part.

A part's hinge i is drawn + offset + SD z_i (z standard normal, independent; see
:mod:`sensor.design_space.scatter`). Around the part cut at the offset (z = 0), each hinge
is moved by +-1 SD alone, and the response is taken as

    log range(z) = a + g . z + 1/2 sum_i c_i z_i^2      (likewise log strain energy)
    u_j(z)       = u_j + J_j . z + 1/2 sum_i C_ji z_i^2 (hinge j's peak stress / allowable)

with central differences of one SD (the secant over the scatter itself, not a tangent;
where a hinge one SD thinner cannot be made, the forward secant and no curvature).
The peak utilisation of a part is max_j u_j(z): per hinge the stress is smooth in the
thicknesses, and the largest of them is taken part by part, so the kink where the governing
hinge changes (an asymmetric part next to the toggle loads one side's hinges more, whichever
side is thinner) is kept. This is the moment method of reliability analysis carried to
second order on the diagonal (Madsen, Krenk and Lind, *Methods of Structural Safety*,
1986), the percentiles then taken over many draws of z, where solving costs nothing. (The
stress' curvature was added in stop 57: on the 10 N nominal answer, 45 % of whose parts
exceed the allowable stress on 400 draws, it took the surface's P(stress) from 0.037 under
the Monte Carlo's to 0.016 on those draws.)

The mirror symmetry of the body halves the solves: on a mirror-symmetric drawing, moving a
right-hand hinge is the mirror image of moving its left-hand twin (1 + 2 x 6 solves for the
DACM, 1 + 2 x 4 for the basis body, against a Monte Carlo's 200); a drawing that is not
symmetric has every hinge moved. On the 5, 10 and 15 N nominal and robust answers of
docs/design-table.json, on the same 200 draws, the surface's range percentiles were within
0.9 % of the Monte Carlo's, its median H within 0.4 % and P(stress > allowable) within
0.01 (0.005 at 39 and 90 % on the nominal 10 and 15 N answers, 0.005-0.010 near 5 % on the
robust ones; one-off run, stop 57); tests/design_space/test_surrogate.py checks five
bodies on 400 draws (next to the toggle, not symmetric, a robust answer, off the toggle,
and one a hinge of which cannot be cut one SD thinner).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import betainc
from scipy.stats import norm, qmc

from geometry.params import Design
from geometry.process import Process
from sensor.design_space.optimise import used_pairs
from sensor.design_space.scatter import as_cut, makeable, used_thickness_mm
from sensor.mechanics.hysteresis import StrainEnergyLaw
from sensor.mechanics.stress import peak_stresses

#: The seed of :func:`surface_draws`' scrambling.
SOBOL_SEED = 0
#: Width of the smoothed step at min_feature_mm in :meth:`ResponseSurface.weighted_parts`,
#: in SD of the process.
MADE_SMOOTHING = 0.1


@dataclass(frozen=True, eq=False)
class ResponseSurface:
    """The response of a drawing's parts to their hinges' deviates z (12,): log range (log
    N) and log strain energy (log mJ) as value, gradient and diagonal curvature (per unit z),
    and each used hinge's utilisation (value (h,), Jacobian (h, 12), diagonal curvature
    (h, 12))."""

    design: Design
    process: Process
    log_range: tuple[float, np.ndarray, np.ndarray]
    log_strain_energy: tuple[float, np.ndarray, np.ndarray]
    utilisation: tuple[np.ndarray, np.ndarray, np.ndarray]

    def parts(self, z: np.ndarray, law: StrainEnergyLaw) -> dict[str, np.ndarray]:
        """Per draw of z (draws, 12) that can be made (every used hinge >= min_feature_mm, as
        :func:`sensor.design_space.scatter.as_cut`): range (N), hysteresis and peak
        utilisation, as :func:`sensor.design_space.tolerance.part_statistics` gives them
        for solved parts."""
        z = np.asarray(z)
        return self._read(z[makeable(self.design, self.process.as_cut(self.design.hinge_thickness_mm, z))], law)

    def weighted_parts(self, z: np.ndarray, law: StrainEnergyLaw) -> dict[str, np.ndarray]:
        """:meth:`parts` for every draw of z, each with a ``weight`` in [0, 1], its chance
        of being made smoothed over MADE_SMOOTHING SD of each used hinge (a step at
        min_feature_mm in the limit): the search's reading, smooth in the drawing (a hard
        cut drops or adds a draw as a hinge's drawn thickness crosses it, one or two draws
        in a forward-difference step at the 0.3 mm hinge minimum; 1.7 estimated, stop 58)."""
        z = np.asarray(z)
        t = used_thickness_mm(self.design, self.process.as_cut(self.design.hinge_thickness_mm, z))
        margin = (t - self.design.min_feature_mm) / (MADE_SMOOTHING * self.process.sd_mm)
        return {**self._read(z, law), "weight": np.exp(norm.logcdf(margin).sum(axis=1))}

    def _read(self, z: np.ndarray, law: StrainEnergyLaw) -> dict[str, np.ndarray]:
        """Range (N), hysteresis and peak utilisation of the parts with deviates z."""
        def quadratic(v, g, c):
            return v + z @ g + 0.5 * (z * z) @ c

        u0, J, C = self.utilisation
        return {"range_N": np.exp(quadratic(*self.log_range)),
                "hysteresis": np.asarray(law.predict(np.exp(quadratic(*self.log_strain_energy)))),
                "utilisation": (u0[None, :] + z @ J.T + 0.5 * (z * z) @ C.T).max(axis=1)}


def surface_draws(n: int) -> np.ndarray:
    """n standard normal deviates (n x 12) from a scrambled Sobol sequence of fixed seed: the
    same for every drawing and every report's seed (a search on them sees the process, not a
    sample), and spread more evenly than random draws (n a power of 2)."""
    return norm.ppf(qmc.Sobol(d=12, scramble=True, seed=SOBOL_SEED).random(n))


def mirror_of(design: Design) -> dict[int, int]:
    """Each used hinge's mirror image (hinge numbers of Figure 48)."""
    pairs = used_pairs(design)
    return {**{a: b for a, b in pairs}, **{b: a for a, b in pairs}}


def _secant(f: np.ndarray, up: int, down: int, down_made: bool) -> tuple[np.ndarray, np.ndarray]:
    """Slope and curvature of the values ``f`` (draws, ...) per unit z from the draws moved
    by +1 SD (``up``) and -1 SD (``down``) about draw 0: central, or where the part moved
    down cannot be made (``down_made`` False), the forward secant with no curvature (a
    drawing within one SD of min_feature_mm is still read, not stalled on; the read jumps
    from one to the other where a drawn hinge crosses min_feature_mm - offset + SD, which
    the default process' 0.3 mm drawn minimum keeps clear of)."""
    if not down_made:
        return f[up] - f[0], np.zeros_like(f[0])
    return (f[up] - f[down]) / 2, f[up] - 2 * f[0] + f[down]


def response_surface(design: Design, process: Process, travel_mm: float) -> ResponseSurface | None:
    """The response surface of ``design``'s parts cut by ``process``, solved to the output
    travel (mm); None where the part cut at the offset cannot be made, or a part of it does
    not solve (the search then reads a flat penalty: a part one SD thinner that can be cut
    but does not solve is taken as a fault of the drawing, not read one-sided). A
    mirror-symmetric drawing moves its left-hand hinges only (a right-hand move is its
    twin's mirror image); any other moves every used hinge."""
    t = design.hinge_thickness_mm
    pairs = used_pairs(design)
    mirror = mirror_of(design)
    symmetric = all(t[a - 1] == t[b - 1] for a, b in pairs)
    used = list(design.used_hinges)
    moved = [a for a, _ in pairs] if symmetric else used
    z = np.zeros((1 + 2 * len(moved), 12))
    for k, h in enumerate(moved):
        z[1 + 2 * k, h - 1], z[2 + 2 * k, h - 1] = 1.0, -1.0
    cut = as_cut(design, z, process.sd_mm, process.offset_mm, travel_mm)
    if not cut.makeable[0] or any(r is None for r in cut.results):
        return None
    allow = design.material.allowable_stress_MPa
    rows = np.flatnonzero(cut.makeable)
    log_range, log_se = np.full(len(z), np.nan), np.full(len(z), np.nan)
    util = np.full((len(z), len(used)), np.nan)    # (parts, used hinges), hinge-number order
    log_range[rows] = np.log([r.input_force_N for r in cut.results])
    log_se[rows] = np.log([r.strain_energy_mJ for r in cut.results])
    util[rows] = peak_stresses(cut.models, cut.results) / allow
    column = {h: j for j, h in enumerate(used)}
    swap = [column[mirror[h]] for h in used] if symmetric else None
    g_r, c_r, g_e, c_e = (np.zeros(12) for _ in range(4))
    J, C = np.zeros((len(used), 12)), np.zeros((len(used), 12))
    for k, h in enumerate(moved):
        up, down = 1 + 2 * k, 2 + 2 * k
        made = bool(cut.makeable[down])
        (gr, cr), (ge, ce), (gu, cu) = (_secant(f, up, down, made) for f in (log_range, log_se, util))
        g_r[h - 1], c_r[h - 1], g_e[h - 1], c_e[h - 1] = gr, cr, ge, ce
        J[:, h - 1], C[:, h - 1] = gu, cu
        if symmetric:   # the twin's move: the same range and energy; hinge j responds as its twin did
            i = mirror[h] - 1
            g_r[i], c_r[i], g_e[i], c_e[i] = gr, cr, ge, ce
            J[:, i], C[:, i] = gu[swap], cu[swap]
    return ResponseSurface(design, process, (float(log_range[0]), g_r, c_r), (float(log_se[0]), g_e, c_e),
                           (util[0], J, C))


def smooth_percentile(values: np.ndarray, weights: np.ndarray, q: float) -> float:
    """The q-th percentile of ``values`` with ``weights`` by the weighted Harrell-Davis
    estimator (Harrell and Davis, Biometrika 69, 1982; weighted with Kish's effective sample
    size: Akinshin, arXiv:2304.07265, 2023): a Beta-weighted mean of every order statistic,
    smooth in the values and the weights, where np.percentile jumps as one value passes
    another or a weight changes."""
    w = np.asarray(weights, dtype=float)
    if len(w) == 0 or w.min() < 0 or not w.sum() > 0:
        raise ValueError(f"weights: {len(w)} weights, sum {w.sum():g}, least {w.min() if len(w) else 0:g}: "
                         "must be at least one, none negative, and sum above 0")
    order = np.argsort(values)
    x, w = np.asarray(values)[order], w[order] / w.max()
    n = w.sum() ** 2 / np.dot(w, w)
    p = q / 100.0
    edges = betainc(p * (n + 1), (1 - p) * (n + 1), np.clip(np.concatenate([[0.0], np.cumsum(w)]) / w.sum(), 0, 1))
    return float(np.dot(np.diff(edges), x))
