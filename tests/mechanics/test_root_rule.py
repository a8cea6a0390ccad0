"""The root rule of the part as cut is the least-squares fit to the continuum FE (DESIGN
sections 14 and 16).

The four constants of :mod:`geometry.topology`'s root rule (``ROOT_DEPTH_PER_THICKNESS``,
``ROOT_DEPTH_PER_LEAN``, ``FILLET_SPREAD_SLOPE``, ``ROOT_BODY_DEPTHS``) are fitted, by least squares on the
relative k_out error in the linear limit, to the entries of
tests/mechanics/data/continuum_table.json that are not held out. The test refits them
(Nelder-Mead from the stored values, each constant not negative) and accepts the stored constants when their RMS error
is within 0.1 percentage point of the refit's (the constants are correlated, so their
values can move more than the fit's quality does). The held-out entries are checked against
the issue's targets by tests/mechanics/test_continuum_table.py with the stored constants.

The stress rule's two constants (:mod:`sensor.mechanics.stress` ``KT_SCALE``,
``KT_EXPONENT``) are fitted the same way to the FE's peak stress in the hinge roots of the
cut entries, and every cut entry is checked against the issue's 10 % on it.
"""

import numpy as np
import pytest
from scipy.optimize import minimize

import geometry.topology as topology
from geometry.params import design_from_dict
from sensor.mechanics import stress
from sensor.mechanics.continuum import LINEAR_LIMIT_FRACTION
from sensor.mechanics.solver import solve
from tests.mechanics.make_continuum_table import HELD_OUT_FAMILIES
from tests.mechanics.test_continuum_table import ENTRIES

CONSTANTS = ("ROOT_DEPTH_PER_THICKNESS", "ROOT_DEPTH_PER_LEAN", "FILLET_SPREAD_SLOPE", "ROOT_BODY_DEPTHS")
KT_CONSTANTS = ("KT_SCALE", "KT_EXPONENT")
FITTED = sorted(n for n, row in ENTRIES.items() if not row["held_out"])


def rms_k_error_pct(values, monkeypatch) -> float:
    for name, v in zip(CONSTANTS, values):
        monkeypatch.setattr(topology, name, float(v))
    topology.hinge_profile.cache_clear()
    errors = []
    for name in FITTED:
        row = ENTRIES[name]
        r = solve(topology.build_beam_model(design_from_dict(row["design"])), target_output_mm=LINEAR_LIMIT_FRACTION)
        errors.append(100 * (r.k_out_N_per_mm / row["linear"]["k_out_N_per_mm"]["extrapolated"] - 1))
    topology.hinge_profile.cache_clear()
    return float(np.sqrt(np.mean(np.square(errors))))


def test_fit_uses_a_body_of_every_kind_and_holds_a_third_out():
    kinds = {ENTRIES[n]["family"] for n in FITTED}
    kerfs = {ENTRIES[n]["kerf_mm"] for n in FITTED}
    assert len(kinds) >= 3 and {0.0, 0.8} <= kerfs
    # every third of a family (the table partly computed), beside the families held out whole
    ruled = [row["held_out"] for row in ENTRIES.values() if row["family"] not in HELD_OUT_FAMILIES]
    assert 0.2 <= sum(ruled) / len(ruled) <= 0.45


def test_root_rule_is_the_least_squares_fit(monkeypatch):
    """Within the constants' physical range (depths and a spread slope are not negative)."""
    stored = [getattr(topology, n) for n in CONSTANTS]
    at_stored = rms_k_error_pct(stored, monkeypatch)
    best = minimize(lambda p: rms_k_error_pct(p, monkeypatch), stored, method="Nelder-Mead",
                    bounds=[(0.0, None)] * len(CONSTANTS),
                    options={"xatol": 1e-3, "fatol": 1e-3, "maxiter": 80})
    assert at_stored <= best.fun + 0.1, (best.x, best.fun, at_stored)


def test_root_rule_fits_within_half_the_k_target(monkeypatch):
    """The fit's RMS k_out error within half the issue's 3 % target."""
    assert rms_k_error_pct([getattr(topology, n) for n in CONSTANTS], monkeypatch) < 1.5


CUT = sorted(n for n, row in ENTRIES.items() if row["kerf_mm"] > 0)


def _peak_errors_pct(name: str) -> dict[int, float]:
    """Beam peak stress against the FE's converged peak in the hinge's roots (percent), on
    every hinge carrying at least half the body's largest peak (the hinges the stress rule
    is about; a lightly loaded hinge whose moment barely changes along it has no root peak
    to speak of), linear, at 1 mm output."""
    row = ENTRIES[name]
    model = topology.build_beam_model(design_from_dict(row["design"]))
    r = solve(model, target_output_mm=LINEAR_LIMIT_FRACTION)
    beam = {h: s.peak_MPa / r.output_travel_mm for h, s in stress.hinge_stresses(model, r).items()}
    fe = {int(h): v for h, v in row["hinge_peak_stress_MPa"].items()}
    top = max(fe.values())
    return {h: 100 * (beam[h] / v - 1) for h, v in fe.items() if v >= 0.5 * top}


@pytest.mark.parametrize("name", CUT)
def test_fillet_peak_stress_within_10_percent_of_the_continuum(name):
    """Beam peak (each root fillet's Kt x its face's stress where the neck starts, the
    largest of the four) within the issue's 10 % of the FE's (meshed to resolve the fillets:
    its three-mesh Richardson error is in the table)."""
    misses = {h: f"{e:+.1f} %" for h, e in _peak_errors_pct(name).items() if abs(e) > 10}
    assert not misses, misses


def rms_peak_error_pct(values, monkeypatch) -> float:
    for name, v in zip(KT_CONSTANTS, values):
        monkeypatch.setattr(stress, name, float(v))
    errors = [e for n in CUT if not ENTRIES[n]["held_out"] for e in _peak_errors_pct(n).values()]
    return float(np.sqrt(np.mean(np.square(errors))))


def test_kt_rule_is_the_least_squares_fit(monkeypatch):
    """KT_SCALE and KT_EXPONENT are the least-squares fit of the beam's peak to the FE's on
    the governing hinges of the cut entries not held out: the stored values' RMS error is
    within 0.1 percentage point of a refit's."""
    stored = [getattr(stress, n) for n in KT_CONSTANTS]
    at_stored = rms_peak_error_pct(stored, monkeypatch)
    best = minimize(lambda p: rms_peak_error_pct(p, monkeypatch), stored, method="Nelder-Mead",
                    options={"xatol": 1e-3, "fatol": 1e-3, "maxiter": 60})
    assert at_stored <= best.fun + 0.1, (best.x, best.fun, at_stored)
