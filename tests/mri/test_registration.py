"""The shift-and-gain fit of a - b (mri.registration) against independent computations:
numpy's own gradient, and a least-squares solve of the full N x 4 design matrix."""

from __future__ import annotations

import numpy as np

from mri.registration import _binned, _gradient, shift_and_gain
from tests.mri.phantoms import noisy_pair, phantom


def test_gradient_is_numpys_to_the_bit():
    # written into its outputs without temporaries; the same operations as np.gradient
    rng = np.random.default_rng(2)
    for shape in ((2, 2), (2, 7), (3, 3), (40, 17), (128, 128)):
        image = rng.normal(0.0, 1e3, shape) * rng.uniform(1e-3, 1e5)
        for mine, numpys in zip(_gradient(image), np.gradient(image)):
            np.testing.assert_array_equal(mine, numpys)


def design_matrix_fit(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(gain, shift rows, shift cols, offset) by lstsq on the N x 4 design matrix."""
    a, b = a.astype(np.float64), b.astype(np.float64)
    mean = (a + b) / 2
    grad_r, grad_c = np.gradient(mean)
    design = np.column_stack([-mean.ravel(), grad_r.ravel(), grad_c.ravel(), np.ones(mean.size)])
    return np.linalg.lstsq(design, (a - b).ravel(), rcond=None)[0]


def test_normal_equations_agree_with_the_design_matrix_fit():
    # the 4 x 4 normal equations square the condition number: agreement to 1e-7 of each
    # coefficient's scale (shifts in pixels, gain dimensionless) is far below the checks'
    # limits (0.3 px, 2 %); on 128 x 128 (no binning) and 256 x 256 (2 x 2 means)
    for shape, shift in (((128, 128), 0.2), ((256, 256), 0.4)):
        image = phantom(shape=shape, centre=(shape[0] / 2 - 3.3, shape[1] / 2 + 2.1), radius=shape[0] / 3)
        moved = phantom(shape=shape, centre=(shape[0] / 2 - 3.3 + shift, shape[1] / 2 + 2.1), radius=shape[0] / 3)
        a, _ = noisy_pair(image, 10.0, seed=1)
        b, _ = noisy_pair(moved * 1.01, 10.0, seed=2)
        fit = np.array(shift_and_gain(a, b))
        if min(shape) >= 256:
            expected = design_matrix_fit(_binned(a), _binned(b)) * [1, 2, 2, 1]
        else:
            expected = design_matrix_fit(a, b)
        np.testing.assert_allclose(fit[:3], expected[:3], rtol=0, atol=1e-7)
        assert abs(fit[1] - shift) < 0.1 and abs(fit[0] - 0.01) < 0.003  # b moved down, 1 % brighter
