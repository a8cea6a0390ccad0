"""Compare fresh values with the stored reference (tests/regression/data/reference.npz).

Tolerance: 1e-6 relative (issue 17: the performance work must not change results). Arrays
are compared against their own scale (largest |value|), so entries that are zero by symmetry
(a rotation on the axis, a member force of 1e-12 N) are held to 1e-6 of the array's scale,
not to 1e-6 of themselves.
"""

from pathlib import Path

import numpy as np

PATH = Path(__file__).with_name("data") / "reference.npz"
RTOL = 1e-6


def load() -> dict[str, np.ndarray]:
    with np.load(PATH) as z:
        return {k: z[k] for k in z.files if k != "commit"}


def relative_deviation(new, ref) -> float:
    """max |new - ref| / max |ref| over finite entries; inf if the NaN patterns differ."""
    new, ref = np.asarray(new, dtype=float), np.asarray(ref, dtype=float)
    if new.shape != ref.shape or not np.array_equal(np.isnan(new), np.isnan(ref)):
        return np.inf
    ok = np.isfinite(ref)
    if not ok.any():
        return 0.0
    scale = np.max(np.abs(ref[ok]))
    return float(np.max(np.abs(new[ok] - ref[ok])) / scale) if scale > 0 else float(np.max(np.abs(new[ok])))


def deviations(values: dict[str, np.ndarray], ref: dict[str, np.ndarray]) -> dict[str, float]:
    """Relative deviation of every value present in both; exact match for bool and str arrays."""
    out = {}
    for k, v in values.items():
        r = ref[k]
        if r.dtype.kind in "bUSO":
            out[k] = 0.0 if np.array_equal(np.asarray(v), r) else np.inf
        else:
            out[k] = relative_deviation(v, r)
    return out
