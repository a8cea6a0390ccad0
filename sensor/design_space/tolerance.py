"""The tolerance report of a design (DESIGN section 16): what the parts cut from its drawing do,
by Monte Carlo over the process' as-cut scatter (:class:`geometry.process.Process`: each hinge
drawn + offset + N(0, SD), independently; default 200 seeded draws, solved as one batch).

It gives the range at the 5th, 50th and 95th percentiles, the hysteresis at the 10th, 50th
and 90th, the probability that a part's peak hinge stress exceeds the allowable stress (a draw
that does not solve to the travel counts as exceeding it), the yield (the fraction of parts
with every hinge at or above ``min_feature_mm``) and the sensitivity of the range to each
hinge group (central difference, both hinges of a pair thickened together, N per 0.01 mm).
Percentiles and the stress probability are over the parts that can be made.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from geometry.params import Design
from geometry.process import WATER_JET, Process
from sensor.design_space.optimise import solve_designs, used_pairs
from sensor.design_space.scatter import AsCut, as_cut
from sensor.mechanics.hysteresis import DEFAULT_LAW, StrainEnergyLaw
from sensor.mechanics.stress import stress_check

DRAWS = 200
#: The step of the range sensitivity (mm): +-0.005 mm around the drawing, reported per 0.01 mm.
SENSITIVITY_STEP_MM = 0.005


@dataclass(frozen=True)
class Tolerance:
    """The tolerance report (N, fractions)."""

    draws: int
    seed: int
    process: dict
    range_N_p5: float
    range_N_p50: float
    range_N_p95: float
    hysteresis_fraction_p10: float
    hysteresis_fraction_p50: float
    hysteresis_fraction_p90: float
    p_over_stress: float
    yield_fraction: float
    range_sensitivity_N_per_0p01mm: dict

    def to_dict(self) -> dict:
        return asdict(self)


def draws_z(draws: int = DRAWS, seed: int = 0) -> np.ndarray:
    """The standard normal deviates (draws x 12) of a report: the same for every design of a
    seed (common random numbers: designs of one report are compared on equal parts)."""
    return np.random.default_rng(seed).standard_normal((draws, 12))


def part_statistics(cut: AsCut, law: StrainEnergyLaw = DEFAULT_LAW) -> dict[str, np.ndarray]:
    """Per makeable draw: range (N), hysteresis, stress utilisation (NaN, NaN, inf where the
    solve failed)."""
    rng, h, util = [], [], []
    for d, m, r in zip(cut.designs, cut.models, cut.results):
        if r is None:
            rng.append(np.nan), h.append(np.nan), util.append(np.inf)
            continue
        rng.append(r.input_force_N)
        h.append(float(law.predict(r.strain_energy_mJ)))
        util.append(stress_check(d, m, r).utilisation)
    return {"range_N": np.array(rng), "hysteresis": np.array(h), "utilisation": np.array(util)}


def range_sensitivity(design: Design, travel_mm: float = 1.0) -> dict[str, float]:
    """d range / d t of each mirror pair (N per 0.01 mm; both hinges together, central
    difference of +-SENSITIVITY_STEP_MM), keyed "a-b"."""
    pairs = used_pairs(design)
    designs = []
    for g in pairs:
        for sign in (1, -1):
            t = list(design.hinge_thickness_mm)
            for h in g:
                t[h - 1] += sign * SENSITIVITY_STEP_MM
            designs.append(design.replace(hinge_thickness_mm=tuple(t)))
    solved = solve_designs(designs, travel_mm)
    f = [np.nan if m is None else r.input_force_N for m, r in solved]
    scale = 0.01 / (2 * SENSITIVITY_STEP_MM)
    return {f"{g[0]}-{g[1]}": float((f[2 * k] - f[2 * k + 1]) * scale) for k, g in enumerate(pairs)}


def tolerance(design: Design, process: Process = WATER_JET, draws: int = DRAWS, seed: int = 0,
              travel_mm: float = 1.0, law: StrainEnergyLaw = DEFAULT_LAW) -> Tolerance:
    """The tolerance report of ``design`` (its drawing) cut by ``process``."""
    cut = as_cut(design, draws_z(draws, seed), process.sd_mm, process.offset_mm, travel_mm)
    s = part_statistics(cut, law)
    ok = np.isfinite(s["range_N"])

    def pct(v, q):
        return float(np.percentile(v[ok], q)) if ok.any() else float("nan")

    return Tolerance(draws, seed, {"name": process.name, "offset_mm": process.offset_mm, "sd_mm": process.sd_mm},
                     pct(s["range_N"], 5), pct(s["range_N"], 50), pct(s["range_N"], 95),
                     pct(s["hysteresis"], 10), pct(s["hysteresis"], 50), pct(s["hysteresis"], 90),
                     float(np.mean(s["utilisation"] > 1)) if len(s["utilisation"]) else float("nan"),
                     float(cut.makeable.mean()), range_sensitivity(design, travel_mm))


def tolerance_text(t: Tolerance) -> list[str]:
    """The report as lines of text."""
    sens = ", ".join(f"({k}) {v:+.3f}" for k, v in t.range_sensitivity_N_per_0p01mm.items())
    return [f"as cut ({t.process['name']}: hinges drawn {t.process['offset_mm']:+.3f} mm, SD {t.process['sd_mm']:g} mm; "
            f"{t.draws} draws, seed {t.seed}):",
            f"  range {t.range_N_p5:.3f} / {t.range_N_p50:.3f} / {t.range_N_p95:.3f} N (5/50/95 %), "
            f"H {t.hysteresis_fraction_p10:.4f} / {t.hysteresis_fraction_p50:.4f} / {t.hysteresis_fraction_p90:.4f} (10/50/90 %)",
            f"  P(stress > allowable) {100 * t.p_over_stress:.1f} %, yield {100 * t.yield_fraction:.1f} % "
            f"(every hinge >= min_feature_mm)",
            f"  range per 0.01 mm of hinge pair, N: {sens}"]
