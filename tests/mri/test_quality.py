"""Quality warnings: each case the issue names raises its code, the clean pair raises none.

The cases are made from the real Siemens Aera pair (NEMA SNR 220, thesis 136.9, no warning)
by the change named, so each warning is checked against a known cause:

* b shifted by 3 px (np.roll): ``misregistration`` (the first-order fit on 2 x 2 means reads
  3.6 px, over the 0.3 px limit);
* b x 0.95: ``gain_change`` (-5 %, over the 2 % limit);
* a dark insert under the upper-left box in both images (the same 90 % of the box's mean
  signal taken off both, so the noise stays): ``outlier_box`` naming that box (its SNR falls
  tenfold);
* a synthetic phantom under exponential surface-coil shading (the far edge at 10 % of the near
  one, Rician sigma 20): the centre is found within 2 px (the signal-fraction threshold of
  the previous version cut the dim side off) and the boxes' spread raises ``outlier_box``;
  shading that sinks the far edge under the noise (2 %) raises ``low_inlier_fraction`` and
  ``centroid_disagreement`` instead of passing silently.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mri
from mri.phantom import find_phantom
from tests.mri.phantoms import noisy_pair, phantom

PAIR = Path(__file__).resolve().parents[1] / "data" / "mri" / "siemens_aera_pair"


@pytest.fixture(scope="module")
def aera():
    return mri.load_pair(PAIR / "tra_250_2meas_1.IMA", PAIR / "tra_250_2meas_2.IMA")


def codes(pair):
    return [w.code for w in pair.warnings]


def with_pixels(image, pixels):
    return dataclasses.replace(image, pixels=np.asarray(pixels, dtype=np.float64))


def test_the_clean_pair_has_no_warning(aera):
    pair = mri.measure_pair(*aera)
    assert codes(pair) == []


def test_a_three_pixel_shift_warns_misregistration(aera):
    a, b = aera
    pair = mri.measure_pair(a, with_pixels(b, np.roll(b.pixels, 3, axis=1)))
    assert "misregistration" in codes(pair)
    warning = next(w for w in pair.warnings if w.code == "misregistration")
    assert 2.0 < warning.values["shift_row_px"] < 4.5  # a first-order fit: roughly
    assert pair.result.summary("thesis").snr < 0.2 * 136.9  # the number it protects


def test_a_gain_of_095_warns_gain_change(aera):
    a, b = aera
    pair = mri.measure_pair(a, with_pixels(b, 0.95 * b.pixels))
    warning = next(w for w in pair.warnings if w.code == "gain_change")
    assert warning.values["gain_percent"] == pytest.approx(-5.0, abs=0.5)
    assert "misregistration" not in codes(pair)


def test_a_dark_insert_under_one_box_warns_outlier_box(aera):
    a, b = aera
    clean = mri.measure_pair(a, b)
    upper_left = clean.result.slices[0].methods[1].rois[1]  # nema: centre, upper-left, ...
    row, col = (int(v) for v in upper_left.roi.split("box:")[1].split(":")[:2])
    rr, cc = np.indices(a.pixels.shape[1:])
    insert = np.hypot(rr - (row + 9.5), cc - (col + 9.5)) <= 16  # covers the 20 x 20 box
    dark = np.where(insert, 0.9 * upper_left.signal, 0.0)  # less signal, the same noise
    pair = mri.measure_pair(with_pixels(a, a.pixels - dark), with_pixels(b, b.pixels - dark))
    warning = next(w for w in pair.warnings if w.code == "outlier_box" and w.values["method"] == "nema")
    assert list(warning.values["rois"]) == [upper_left.roi]
    assert pair.result.summary("nema").snr < 0.9 * clean.result.summary("nema").snr


def exponential(far: float):
    """A disc (radius 95 px, centre (121.3, 133.6)) whose brightness falls exponentially from
    its left edge to ``far`` of it at the right edge, as a surface coil on the left makes it."""
    centre = (121.3, 133.6)
    truth = phantom(centre=centre)
    cols = np.indices(truth.shape)[1]
    return centre, truth * far ** ((cols - (centre[1] - 95.0)) / 190.0)


def test_exponential_shading_is_found_within_2_px_and_warns_outlier_box():
    centre, truth = exponential(0.10)
    a, b = noisy_pair(truth, 20.0, seed=3)
    _, fit = find_phantom(a)
    assert np.hypot(*np.subtract(fit.centre_px, centre)) < 2.0
    pair = mri.measure_pair(mri.MriImage(a[None], "a.npy", "npy"), mri.MriImage(b[None], "b.npy", "npy"))
    assert "outlier_box" in codes(pair)
    assert not {"low_inlier_fraction", "centroid_disagreement"} & set(codes(pair))


def test_shading_below_the_noise_warns_instead_of_passing_silently():
    _, truth = exponential(0.02)
    a, b = noisy_pair(truth, 20.0, seed=3)
    pair = mri.measure_pair(mri.MriImage(a[None], "a.npy", "npy"), mri.MriImage(b[None], "b.npy", "npy"))
    assert {"low_inlier_fraction", "centroid_disagreement"} <= set(codes(pair))


def test_a_different_object_in_b_is_refused_with_both_centres():
    a, _ = noisy_pair(phantom(centre=(121.3, 133.6), radius=60.0), 20.0, seed=1)
    b, _ = noisy_pair(phantom(centre=(131.3, 133.6), radius=60.0), 20.0, seed=2)
    with pytest.raises(mri.PairMismatchError, match=r"121\.\d, 133\.\d\) and in b \(131\.\d, 133\.\d.* 10\.0 px apart"):
        mri.measure_pair(mri.MriImage(a[None], "a.npy", "npy"), mri.MriImage(b[None], "b.npy", "npy"))


def test_warnings_are_coded_in_json_and_on_stderr(aera, tmp_path, capsys):
    import json

    from sensor.cli import main

    a, b = aera
    np.save(tmp_path / "a.npy", a.pixels)
    np.save(tmp_path / "b.npy", 0.95 * b.pixels)
    assert main(["snr", str(tmp_path / "a.npy"), str(tmp_path / "b.npy"), "--json"]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert [w["code"] for w in out["warnings"]] == ["gain_change"]
    assert out["warnings"][0]["values"]["limit_percent"] == 2.0
    assert captured.err == ""  # JSON mode: the warnings are in the JSON
    assert main(["snr", str(tmp_path / "a.npy"), str(tmp_path / "b.npy")]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == [f"dacm snr: warning: {mri.QualityWarning(**out['warnings'][0])}"]
