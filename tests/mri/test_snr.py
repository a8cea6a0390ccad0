"""SNR measures (thesis eqs 91-93, NEMA MS 1) against phantoms of known noise and exact cases.

Statistical tolerances: a sigma estimated from N independent pixels has a relative standard
error of about 1 / sqrt(2 N). The 3 % bound of the spec is checked only with ROIs of at least
8000 pixels (error <= 0.8 %, so 3 % is more than 3.5 standard errors); seeds are fixed.
"""

from __future__ import annotations

import numpy as np
import pytest

from mri.errors import MeasurementError
from mri.roi import Roi, parse_roi, resolve_roi
from mri.snr import (
    difference_percent,
    magnitude_snr,
    measure_arrays,
    measure_roi,
    nema_noise,
    thesis_noise,
)

SIZE = 256
RADIUS = 110  # px; the phantom disc fills most of the image


def disc(size: int = SIZE, radius: float = RADIUS) -> np.ndarray:
    r, c = np.ogrid[:size, :size]
    return ((r - (size - 1) / 2) ** 2 + (c - (size - 1) / 2) ** 2) <= radius**2


def gaussian_pair(signal: float, sigma: float, seed: int, slices: int = 1):
    """Uniform disc of value ``signal`` on 0, plus independent Gaussian noise in a and b."""
    rng = np.random.default_rng(seed)
    truth = np.where(disc(), signal, 0.0)[np.newaxis].repeat(slices, axis=0)
    a = truth + rng.normal(0, sigma, truth.shape)
    b = truth + rng.normal(0, sigma, truth.shape)
    return truth, a, b


def magnitude_pair(signal: float, sigma: float, seed: int):
    """Magnitude images |signal + n1 + i n2| from two Gaussian channels (Rician noise)."""
    rng = np.random.default_rng(seed)
    truth = np.where(disc(), signal, 0.0)[np.newaxis]

    def one():
        return np.hypot(truth + rng.normal(0, sigma, truth.shape), rng.normal(0, sigma, truth.shape))

    return one(), one()


def specs(*texts):
    return tuple(parse_roi(t) for t in texts)


# --------------------------------------------------------------------------- exact cases


def test_thesis_noise_checkerboard_is_exact():
    # V = +-1 checkerboard: every horizontal neighbour difference is +-2, so eq 91 gives
    # SD^2 = 4 n (m-1) / (2 n (m-1)) = 2 and eq 92 Noise = SD / sqrt(2) = 1 exactly.
    v = np.where(np.indices((7, 9)).sum(axis=0) % 2 == 0, 1.0, -1.0)
    assert thesis_noise(v, np.ones_like(v, dtype=bool)) == pytest.approx(1.0, rel=1e-15)


def test_thesis_noise_counts_only_pairs_inside_the_roi():
    # V(i, j) = c j: each pair differs by c, so Noise = sqrt(c^2 / 2) / sqrt(2) = c / 2 for any
    # ROI; a ROI of two single-pixel columns far apart has no pair and is rejected.
    v = 3.0 * np.arange(12.0)[np.newaxis].repeat(5, axis=0)
    mask = np.zeros_like(v, dtype=bool)
    mask[1:4, 2:7] = True
    assert thesis_noise(v, mask) == pytest.approx(1.5, rel=1e-15)
    lonely = np.zeros_like(mask)
    lonely[:, [0, 5]] = True
    with pytest.raises(MeasurementError, match="adjacent"):
        thesis_noise(v, lonely)


def test_thesis_and_difference_sums_over_row_blocks_equal_the_whole_image_formulas():
    # a - b and its neighbour differences are summed a block of rows at a time (several
    # blocks; one row a block when a row exceeds a block); the results are the formulas'
    from mri.snr import BLOCK_ELEMENTS, sum_abs_difference

    rng = np.random.default_rng(12)
    for shape in ((300, 50), (5, BLOCK_ELEMENTS + 7), (1, 3)):
        a = rng.integers(0, 4000, shape).astype(np.float32)
        b = (a + rng.normal(0, 20, shape)).astype(np.float32)
        diff = a.astype(np.float64) - b
        steps = np.diff(diff, axis=1)
        expected = np.sqrt(np.sum(steps**2) / (2 * steps.size)) / np.sqrt(2)
        assert thesis_noise(diff) == pytest.approx(expected, rel=1e-13)
        roi = Roi("whole", None, (0, 0, *shape), shape)
        assert measure_roi(a, b, roi, "thesis").noise == pytest.approx(expected, rel=1e-13)
        assert sum_abs_difference(a, b) == pytest.approx(np.abs(diff).sum(), rel=1e-13)


def test_nema_noise_is_sample_std_over_sqrt2():
    v = np.array([[1.0, -1.0, 1.0, -1.0]])
    # sample std with ddof=1 of four +-1 values: sqrt(4 / 3)
    assert nema_noise(v, np.ones_like(v, dtype=bool)) == pytest.approx(np.sqrt(4 / 3) / np.sqrt(2))


def test_difference_percent_exact():
    a = np.full((10, 10), 100.0)
    b = a.copy()
    b[3, 4] += 50.0
    b[7, 1] -= 30.0
    assert difference_percent(a, b) == pytest.approx(100 * 80 / 10000, rel=1e-15)


def test_difference_of_pure_noise_is_the_half_normal_mean():
    # With no change between a and b, |a - b| is half-normal with mean 2 sigma / sqrt(pi), so
    # the thesis' difference has a noise floor of 100 * 2 sigma / (sqrt(pi) * mean a) percent.
    # 65 536 pixels: relative standard error 0.3 %, checked to 1.5 %.
    sigma = 5.0
    _, a, b = gaussian_pair(400.0, sigma, seed=21)
    floor = 100 * 2 * sigma / (np.sqrt(np.pi) * a.mean())
    assert difference_percent(a[0], b[0]) == pytest.approx(floor, rel=0.015)


def test_identical_images_are_an_error_not_infinity():
    a = np.random.default_rng(0).normal(100, 5, (32, 32))
    roi = Roi("whole", np.ones_like(a, dtype=bool))
    for method in ("thesis", "nema"):
        with pytest.raises(MeasurementError, match="zero noise"):
            measure_roi(a, a.copy(), roi, method)


# --------------------------------------------------------------------------- Gaussian phantoms


@pytest.mark.parametrize("true_snr", [20, 50, 100, 200])
def test_both_methods_recover_gaussian_snr_within_3_percent(true_snr):
    sigma = 7.0
    truth, a, b = gaussian_pair(true_snr * sigma, sigma, seed=true_snr)
    result = measure_arrays(
        a, b, None, {"thesis": specs("phantom"), "nema": specs("nema5:40:50", "phantom")}
    )
    for method in ("thesis", "nema"):
        summary = result.summary(method)
        assert summary.snr == pytest.approx(true_snr, rel=0.03), method
        assert summary.noise == pytest.approx(sigma, rel=0.03), method


@pytest.mark.parametrize("true_snr", [20, 200])
def test_thesis_whole_image_uses_the_mean_of_the_whole_image(true_snr):
    # Eq 93's S is the mean of the original image, background included, so the true SNR of
    # the whole image is mean(truth) / sigma; the noise estimate itself is global.
    sigma = 3.0
    truth, a, b = gaussian_pair(true_snr * sigma, sigma, seed=1000 + true_snr)
    result = measure_arrays(a, b, None, {"thesis": specs("whole")})
    assert result.summary("thesis").snr == pytest.approx(truth.mean() / sigma, rel=0.03)


def test_volume_is_measured_slice_by_slice_with_a_summary():
    rng = np.random.default_rng(5)
    sigmas = np.array([4.0, 8.0, 16.0])  # true SNR 100, 50, 25 for signal 400
    truth = np.where(disc(), 400.0, 0.0)
    a = np.stack([truth + rng.normal(0, s, truth.shape) for s in sigmas])
    b = np.stack([truth + rng.normal(0, s, truth.shape) for s in sigmas])
    result = measure_arrays(a, b, None, {"nema": specs("phantom")})
    snrs = [s.methods[0].snr for s in result.slices]
    assert [s.index for s in result.slices] == [0, 1, 2]
    np.testing.assert_allclose(snrs, 400.0 / sigmas, rtol=0.03)
    summary = result.summary("nema")
    assert summary.snr == pytest.approx(np.mean(snrs), rel=1e-12)
    assert (summary.snr_min, summary.snr_max) == (min(snrs), max(snrs))


# --------------------------------------------------------------------------- Rician bias


@pytest.mark.parametrize("true_snr", [1.0, 2.0, 3.0])
def test_rician_bias_at_low_snr_matches_the_rice_distribution(true_snr):
    # Magnitude images report E[M] / std(M) of the Rice distribution, not A / sigma:
    # ratio 2.00 at SNR 1, 1.24 at 2, 1.09 at 3. Central disc of ~25 000 pixels: 1 % error.
    sigma = 10.0
    a, b = magnitude_pair(true_snr * sigma, sigma, seed=int(10 * true_snr))
    result = measure_arrays(
        a, b, None, {"thesis": specs("central-circle:180"), "nema": specs("central-circle:180")}
    )
    expected = magnitude_snr(true_snr)
    assert expected / true_snr > 1.08  # the bias is real at these SNRs
    for method in ("thesis", "nema"):
        assert result.summary(method).snr == pytest.approx(expected, rel=0.03), method


def test_rician_bias_vanishes_at_high_snr():
    sigma = 10.0
    a, b = magnitude_pair(50 * sigma, sigma, seed=50)
    result = measure_arrays(a, b, None, {"nema": specs("central-circle:180")})
    assert magnitude_snr(50.0) == pytest.approx(50.0, rel=1e-3)
    assert result.summary("nema").snr == pytest.approx(50.0, rel=0.03)


# --------------------------------------------------------------------------- properties


def _measure(a, b, rois=("phantom",)):
    return measure_arrays(a, b, None, {"thesis": specs(*rois), "nema": specs(*rois)})


def test_constant_offset_on_b_does_not_change_the_noise():
    _, a, b = gaussian_pair(500.0, 5.0, seed=11)
    base, shifted = _measure(a, b), _measure(a, b + 123.0)
    for method in ("thesis", "nema"):
        assert shifted.summary(method).noise == pytest.approx(base.summary(method).noise, rel=1e-9)
        assert shifted.summary(method).signal == base.summary(method).signal


def test_swapping_a_and_b_changes_snr_only_within_noise():
    # Noise comes from |a - b| statistics and is unchanged; the signal is the mean of the
    # other image, which differs by sigma / sqrt(N) ~ 0.01 % of it here.
    _, a, b = gaussian_pair(500.0, 5.0, seed=12)
    ab, ba = _measure(a, b), _measure(b, a)
    for method in ("thesis", "nema"):
        assert ba.summary(method).noise == pytest.approx(ab.summary(method).noise, rel=1e-9)
        assert ba.summary(method).snr == pytest.approx(ab.summary(method).snr, rel=1e-3)
        assert ba.summary(method).snr != ab.summary(method).snr


def test_scaled_pair_scales_signal_and_noise_alike():
    _, a, b = gaussian_pair(500.0, 5.0, seed=13)
    k = 3.7
    base = measure_arrays(a, b, None, {"thesis": specs("whole"), "nema": specs("nema5")})
    scaled = measure_arrays(k * a, k * b, None, {"thesis": specs("whole"), "nema": specs("nema5")})
    for method in ("thesis", "nema"):
        s0, s1 = base.summary(method), scaled.summary(method)
        assert s1.signal == pytest.approx(k * s0.signal, rel=1e-12)
        assert s1.noise == pytest.approx(k * s0.noise, rel=1e-12)
        assert s1.snr == pytest.approx(s0.snr, rel=1e-12)
    assert scaled.difference_percent == pytest.approx(base.difference_percent, rel=1e-12)


def test_thesis_method_ignores_a_smooth_drift_that_nema_counts():
    # b drifts by a ramp of 40 over the image (e.g. slow intensity drift): neighbour
    # differences see 40/255 per pixel (negligible against sigma), the ROI std sees the ramp.
    _, a, b = gaussian_pair(500.0, 5.0, seed=14)
    ramp = np.linspace(0.0, 40.0, SIZE)[np.newaxis, np.newaxis, :]
    base, drift = _measure(a, b), _measure(a, b + ramp)
    assert drift.summary("thesis").noise == pytest.approx(base.summary("thesis").noise, rel=0.01)
    assert drift.summary("nema").noise > 1.2 * base.summary("nema").noise


def test_resolved_rois_are_reported_by_label():
    _, a, b = gaussian_pair(500.0, 5.0, seed=15)
    rois = resolve_roi(parse_roi("nema5"), a[0], None)
    result = measure_arrays(a, b, None, {"nema": specs("nema5")})
    assert [r.roi for r in result.slices[0].methods[0].rois] == [r.label for r in rois]
    assert all(r.n_pixels == 400 for r in result.slices[0].methods[0].rois)


def test_magnitude_snr_matches_scipy_rice_moments():
    # Closed form with scaled Bessel functions vs scipy's numerical Rice moments (which
    # overflow above SNR ~ 30, the reason for the closed form).
    from scipy.stats import rice

    for true_snr in (0.0, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0):
        dist = rice(true_snr)
        assert magnitude_snr(true_snr) == pytest.approx(dist.mean() / dist.std(), rel=1e-9)
    assert magnitude_snr(1000.0) == pytest.approx(1000.0, rel=1e-5)


def test_nema_noise_needs_two_pixels():
    from mri.errors import MriError
    from mri.snr import nema_noise
    mask = np.zeros((4, 4), dtype=bool)
    mask[1, 1] = True
    with pytest.raises(MriError, match="1 pixel"):
        nema_noise(np.ones((4, 4)), mask)


def test_volume_slice_whose_boxes_leave_the_phantom_is_skipped_with_its_reason():
    # An 11-slice series: slice 4 has a dark insert under the centre box (measured: the box is
    # inside the phantom, and flagged as an outlier box), slice 7 a notch under the
    # upper-right box (the default boxes move in, with a warning) and slice 10 is empty (past
    # the phantom): it is skipped with its reason, the 10 others are measured.
    from tests.mri.phantoms import noisy_pair, phantom

    truths = [phantom() for _ in range(11)]
    truths[4] = phantom(inserts=((121, 133, 15, 0.02),))
    truths[7] = phantom(notch=(45, 50, 40))
    truths[10] = np.zeros_like(truths[0])
    pairs = [noisy_pair(t, 10.0, seed=k) for k, t in enumerate(truths)]
    a, b = np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])
    result = measure_arrays(a, b, None, {"nema": specs("nema5")})
    skipped = {s.index: s.skipped for s in result.slices if s.skipped}
    assert sorted(skipped) == [10]
    assert "no phantom found" in skipped[10]  # noise above the threshold spans the image
    # the deep notch also pulls the mask's centroid 2+ px from the fitted circle's centre
    assert {w.code for w in result.slices[7].warnings} == {"boxes_shrunk", "centroid_disagreement"}
    assert [w.code for w in result.slices[4].warnings] == ["outlier_box"]
    assert result.slices[4].methods[0].snr > 50
    codes = {w.code: w for w in result.warnings}
    assert codes["boxes_shrunk"].values["slice"] == 7 and codes["outlier_box"].values["slice"] == 4
    measured = [s.methods[0].snr for s in result.slices if not s.skipped]
    assert len(measured) == 10 and result.summary("nema").snr == pytest.approx(np.mean(measured))
    with pytest.raises(MeasurementError, match="no slice of the 2 could be measured"):
        measure_arrays(a[[10, 10]], b[[10, 10]], None, {"nema": specs("nema5")})


def test_volume_slices_measure_as_single_images():
    # each slice of a volume measures as it does alone (float32 pixels as loaded, every pair
    # and single-image method, a skipped slice between)
    from tests.mri.phantoms import noisy_pair, phantom

    truths = [phantom(signal=s) for s in (400.0, 900.0)] + [np.zeros((256, 256)), phantom(kind="rectangle")]
    pairs = [noisy_pair(t + 30.0, 12.0, seed=20 + k) for k, t in enumerate(truths)]
    a = np.stack([p[0] for p in pairs]).astype(np.float32)
    b = np.stack([p[1] for p in pairs]).astype(np.float32)
    methods = {"thesis": specs("whole") + specs("nema5"), "nema": specs("nema5") + specs("phantom"),
               "smoothed": specs("nema5"), "background": specs("nema5")}
    volume = measure_arrays(a, b, (1.0, 1.0), methods)
    assert [bool(s.skipped) for s in volume.slices] == [False, False, True, False]
    for k in (0, 1, 3):
        alone = measure_arrays(a[k : k + 1], b[k : k + 1], (1.0, 1.0), methods).slices[0]
        assert volume.slices[k].methods == alone.methods
        assert volume.slices[k].sum_abs_difference == alone.sum_abs_difference
    assert volume.slices[0].methods[0].snr != volume.slices[1].methods[0].snr
    # float32 pixels measure as their float64 copies (every method works in float64; sums
    # may be added in another order)
    wide = measure_arrays(a.astype(np.float64), b.astype(np.float64), (1.0, 1.0), methods)
    for narrow_slice, wide_slice in zip(volume.slices, wide.slices):
        for narrow, exact in zip(narrow_slice.methods, wide_slice.methods):
            for x, y in zip(narrow.rois, exact.rois):
                assert (x.signal, x.noise, x.snr) == pytest.approx((y.signal, y.noise, y.snr), rel=1e-13)
        assert len(narrow_slice.methods) == len(wide_slice.methods)


@pytest.mark.parametrize("method, rois", [
    ("nema", ("box:10:10:20:20",)),
    ("nema", ("box:2:2:12:12", "box:2:40:12:12", "box:40:2:12:12", "box:40:40:12:12", "box:26:26:12:12")),
    ("thesis", ("box:10:10:20:20",)),
    ("thesis", ("whole",)),
    ("smoothed", ("box:20:20:24:24",)),
])
def test_the_95_percent_interval_covers_the_true_snr_95_percent_of_the_time(method, rois):
    # Monte Carlo against the truth: a uniform image of signal 1000 and Gaussian noise sigma 20
    # (true SNR 50), 600 independent pairs. The coverage must be 95 % within 3 binomial
    # standard deviations (0.9 % each for 600 trials): 92.3-97.7 %. The smoothed method's
    # truth is its published bias, 50 / sqrt(1 - 1/81) (it reads white noise 0.62 % low).
    rng = np.random.default_rng(12)
    truth = 50.0 / (np.sqrt(1 - 1 / 81) if method == "smoothed" else 1.0)
    specs_ = {method: tuple(parse_roi(t) for t in rois)}
    hits = 0
    for _ in range(600):
        a = 1000.0 + rng.normal(0, 20.0, (1, 64, 64))
        b = None if method == "smoothed" else 1000.0 + rng.normal(0, 20.0, (1, 64, 64))
        low, high = measure_arrays(a, b, None, specs_).summaries[0].snr_ci95
        hits += low <= truth <= high
    assert 0.923 <= hits / 600 <= 0.977, hits / 600
