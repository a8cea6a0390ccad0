"""The parts cut from one drawing, by a response surface in the hinges' deviates (DESIGN
section 16): what the robust search (:mod:`sensor.design_space.robust`) reads instead of
solving every part.

A part's hinge i is drawn + offset + SD z_i (z standard normal, independent; see
:mod:`sensor.design_space.scatter`). Around the part cut at the offset (z = 0), each hinge
is moved by +-1 SD alone, and the response is taken as

    log range(z) = a + g . z + 1/2 sum_i c_i z_i^2      (likewise log strain energy)
    u_j(z)       = u_j + J_j . z                        (hinge j's peak stress / allowable)

with central differences of one SD (the secant over the scatter itself, not a tangent).
The peak utilisation of a part is max_j u_j(z): per hinge the stress is smooth in the
thicknesses, and the largest of them is taken part by part, so the kink where the governing
hinge changes (an asymmetric part next to the toggle loads one side's hinges more, whichever
side is thinner) is kept. This is the moment method of reliability analysis carried to
second order on the diagonal (Madsen, Krenk and Lind, *Methods of Structural Safety*,
1986), the percentiles then taken over many draws of z, where solving costs nothing.

The mirror symmetry of the body halves the solves: moving a right-hand hinge is the mirror
image of moving its left-hand twin (1 + 2 x 6 solves for the DACM, 1 + 2 x 4 for the basis
body, against a Monte Carlo's 200). On the 5, 10 and 15 N nominal answers, on the same 200
draws, the surface's range percentiles were within 0.7 % of the Monte Carlo's, its median H
within 1 % and P(stress > allowable) within 0.03 (one-off runs);
tests/design_space/test_surrogate.py checks a body next to the toggle and one off it on 400
draws.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import norm, qmc

from geometry.params import Design
from geometry.process import Process
from sensor.design_space.optimise import PAIRS
from sensor.design_space.scatter import as_cut
from sensor.mechanics.hysteresis import StrainEnergyLaw
from sensor.mechanics.stress import peak_stresses

#: The seed of :func:`surface_draws`' scrambling.
SOBOL_SEED = 0


@dataclass(frozen=True, eq=False)
class ResponseSurface:
    """The response of a drawing's parts to their hinges' deviates z (12,): log range (log
    N) and log strain energy (log mJ) as value, gradient and diagonal curvature (per unit z),
    and each used hinge's utilisation (value (h,), Jacobian (h, 12))."""

    design: Design
    process: Process
    log_range: tuple[float, np.ndarray, np.ndarray]
    log_strain_energy: tuple[float, np.ndarray, np.ndarray]
    utilisation: tuple[np.ndarray, np.ndarray]

    def parts(self, z: np.ndarray, law: StrainEnergyLaw) -> dict[str, np.ndarray]:
        """Per draw of z (draws, 12) that can be made (every used hinge >= min_feature_mm, as
        :func:`sensor.design_space.scatter.as_cut`): range (N), hysteresis and peak
        utilisation, as :func:`sensor.design_space.tolerance.part_statistics` gives them
        for solved parts."""
        d, pr = self.design, self.process
        n = len(d.used_hinges)
        t = np.asarray(d.hinge_thickness_mm) + pr.offset_mm + pr.sd_mm * np.asarray(z)
        z = np.asarray(z)[t[:, :n].min(axis=1) >= d.min_feature_mm]

        def quadratic(v, g, c):
            return v + z @ g + 0.5 * (z * z) @ c

        u0, J = self.utilisation
        return {"range_N": np.exp(quadratic(*self.log_range)),
                "hysteresis": np.asarray(law.predict(np.exp(quadratic(*self.log_strain_energy)))),
                "utilisation": (u0[None, :] + z @ J.T).max(axis=1)}


def surface_draws(n: int) -> np.ndarray:
    """n standard normal deviates (n x 12) from a scrambled Sobol sequence of fixed seed: the
    same for every drawing and every report's seed (a search on them sees the process, not a
    sample), and spread more evenly than random draws (n a power of 2)."""
    return norm.ppf(qmc.Sobol(d=12, scramble=True, seed=SOBOL_SEED).random(n))


def mirror_of(design: Design) -> dict[int, int]:
    """Each used hinge's mirror image (hinge numbers of Figure 48)."""
    pairs = [g for g in PAIRS if g[0] in design.used_hinges]
    return {**{a: b for a, b in pairs}, **{b: a for a, b in pairs}}


def response_surface(design: Design, process: Process, travel_mm: float) -> ResponseSurface | None:
    """The response surface of ``design``'s parts cut by ``process``, solved to the output
    travel (mm); None where a part of it does not solve or cannot be made."""
    mirror = mirror_of(design)
    left = sorted(a for a, b in mirror.items() if a < b)
    used = list(design.used_hinges)
    z = np.zeros((1 + 2 * len(left), 12))
    for k, h in enumerate(left):
        z[1 + 2 * k, h - 1], z[2 + 2 * k, h - 1] = 1.0, -1.0
    cut = as_cut(design, z, process.sd_mm, process.offset_mm, travel_mm)
    if not cut.makeable.all() or any(r is None for r in cut.results):
        return None
    log_range = np.log([r.input_force_N for r in cut.results])
    log_se = np.log([r.strain_energy_mJ for r in cut.results])
    allow = design.material.allowable_stress_MPa
    util = peak_stresses(cut.models, cut.results) / allow   # (parts, used hinges), hinge-number order
    column = {h: j for j, h in enumerate(used)}
    g_r, c_r, g_e, c_e = (np.zeros(12) for _ in range(4))
    J = np.zeros((len(used), 12))
    for k, h in enumerate(left):
        up, down = 1 + 2 * k, 2 + 2 * k
        for i in (h, mirror[h]):   # a hinge and its twin: the same range and energy
            g_r[i - 1], c_r[i - 1] = (log_range[up] - log_range[down]) / 2, log_range[up] - 2 * log_range[0] + log_range[down]
            g_e[i - 1], c_e[i - 1] = (log_se[up] - log_se[down]) / 2, log_se[up] - 2 * log_se[0] + log_se[down]
        for j in used:
            # hinge j's response to the twin's move is its own twin's response to this move
            J[column[j], h - 1] = (util[up, column[j]] - util[down, column[j]]) / 2
            J[column[j], mirror[h] - 1] = (util[up, column[mirror[j]]] - util[down, column[mirror[j]]]) / 2
    return ResponseSurface(design, process, (float(log_range[0]), g_r, c_r), (float(log_se[0]), g_e, c_e),
                           (util[0], J))
