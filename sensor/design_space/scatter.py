"""Bodies as cut: a design's hinges drawn from a scatter model and solved together (the sweep's
Monte Carlo, the tolerance report and the robust design share it; DESIGN section 16).

A draw's hinge is its drawn thickness plus ``offset_mm`` plus ``sd_mm`` times a standard
normal deviate. A draw with a used hinge under ``min_feature_mm`` is a part that could not be
made: it is not solved, and counts against the yield.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geometry.params import Design
from geometry.process import Process
from geometry.topology import build_beam_model
from sensor.mechanics.solver import SolverOptions, solve_batch


@dataclass(frozen=True, eq=False)
class AsCut:
    """Draws of one design: ``thickness_mm`` (draws, 12), ``makeable`` (draws,) mask, and for
    the makeable draws in order their designs, beam models and solve results (None where the
    solve failed)."""

    thickness_mm: np.ndarray
    makeable: np.ndarray
    designs: list
    models: list
    results: list


def as_cut(design: Design, z: np.ndarray, sd_mm: float, offset_mm: float = 0.0, travel_mm: float = 1.0,
           options: SolverOptions = SolverOptions()) -> AsCut:
    """Solve ``design`` with every hinge drawn as drawn + offset_mm + sd_mm z (z: draws x 12
    standard normal deviates) to the output travel."""
    draws = Process(sd_mm=sd_mm, offset_mm=offset_mm).as_cut(design.hinge_thickness_mm, z)
    ok = makeable(design, draws)
    designs = [design.replace(hinge_thickness_mm=tuple(float(v) for v in t)) for t in draws[ok]]
    models = [build_beam_model(d) for d in designs]
    results, _ = solve_batch(models, target_output_mm=travel_mm, options=options) if models else ([], [])
    return AsCut(draws, ok, designs, models, results)


def used_thickness_mm(design: Design, thickness_mm: np.ndarray) -> np.ndarray:
    """(draws, used hinges): the columns of hinges ``thickness_mm`` (draws, 12) that
    ``design`` uses (its used hinges come first in hinge-number order): per draw, what
    :attr:`geometry.params.Design.used_thickness_mm` is for the drawing."""
    return np.asarray(thickness_mm)[:, :len(design.used_hinges)]


def makeable(design: Design, thickness_mm: np.ndarray) -> np.ndarray:
    """(draws,) mask of the parts of ``design`` with hinges ``thickness_mm`` (draws, 12)
    that can be made: every used hinge at least ``min_feature_mm``."""
    return used_thickness_mm(design, thickness_mm).min(axis=1) >= design.min_feature_mm
