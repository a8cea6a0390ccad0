"""``dacm snr`` through ``sensor.cli.main``: outputs, condition comparison and bad input (exit 2)."""

from __future__ import annotations

import csv
import json

import imageio.v3 as iio
import numpy as np
import pytest

from sensor.cli import main

SIZE = 256


def phantom(sigma: float, seed: int, signal: float = 1000.0, slices: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    r, c = np.ogrid[:SIZE, :SIZE]
    truth = np.where((r - 127.5) ** 2 + (c - 127.5) ** 2 <= 110**2, signal, 0.0)
    return truth + rng.normal(0, sigma, (slices, SIZE, SIZE))


@pytest.fixture
def files(tmp_path):
    """A reference pair (SNR 100) and a noisier condition pair (SNR 50), as .npy files."""
    paths = {}
    for name, sigma, seed in [("a1", 10, 1), ("a2", 10, 2), ("b1", 20, 3), ("b2", 20, 4)]:
        paths[name] = tmp_path / f"{name}.npy"
        np.save(paths[name], phantom(sigma, seed)[0])
    return paths


def run(capsys, *args):
    status = main(["snr", *map(str, args)])
    out, err = capsys.readouterr()
    return status, out, err


def test_text_output_lists_both_methods_and_difference(capsys, files):
    status, out, err = run(capsys, files["a1"], files["a2"])
    assert status == 0 and err == ""
    assert "thesis     a-b   whole" in out and "nema       a-b   mean of 5 ROIs" in out
    assert "normalised SNR: not computed, the header lacks pixel_row_mm" in out  # NPY: no header
    assert "difference sum|a-b| / sum a:" in out


def test_json_method_roi_and_csv(capsys, files, tmp_path):
    table = tmp_path / "out.csv"
    status, out, _ = run(capsys, files["a1"], files["a2"], "--method", "nema",
                         "--roi", "box:100:100:30:30", "--roi", "central-circle:60", "--json",
                         "--csv", table)
    assert status == 0
    result = json.loads(out)
    assert result["rois"] == {"nema": ["box:100:100:30:30", "central-circle:60"]}
    (summary,) = result["summaries"]
    assert summary["method"] == "nema"
    assert summary["snr"] == pytest.approx(100.0, rel=0.05)  # two ROIs, ~3700 px: 1.2 % error
    rows = list(csv.DictReader(table.open()))
    assert [r["roi"] for r in rows] == ["box:100:100:30:30", "central-circle:60"]


def test_volume_prints_per_slice_and_summary(capsys, tmp_path):
    np.save(tmp_path / "va.npy", phantom(10, 1, slices=3))
    np.save(tmp_path / "vb.npy", phantom(10, 2, slices=3))
    status, out, _ = run(capsys, tmp_path / "va.npy", tmp_path / "vb.npy", "--method", "thesis")
    assert status == 0
    assert "thesis over 3 of 3 slices: SNR mean" in out
    assert sum(line.strip().startswith(("0 ", "1 ", "2 ")) for line in out.splitlines()) == 3


def test_conditions_report_snr_change_and_difference(capsys, files, tmp_path):
    figure = tmp_path / "conditions.png"
    status, out, _ = run(
        capsys, "--reference", files["a1"], files["a2"],
        "--condition", "sensor", files["b1"], files["b2"],
        "--roi", "phantom", "--json", "--figure", figure,
    )
    assert status == 0
    result = json.loads(out)
    (condition,) = result["conditions"]
    # SNR 100 -> 50: -50 %, within the ~0.6 % estimation error of each pair (3 % bound).
    for method in ("thesis", "nema"):
        assert condition["snr_change_percent"][method] == pytest.approx(-50.0, abs=3.0)
    # |A1 - B1| is |N(0, 10) - N(0, 20)| = half-normal of sigma sqrt(500) in every pixel:
    # mean sqrt(2/pi) sqrt(500) = 17.84 per pixel, over the mean of A1.
    a1 = np.load(files["a1"])
    expected = 100 * np.sqrt(2 / np.pi) * np.sqrt(500) / a1.mean()
    assert condition["difference_vs_reference_percent"] == pytest.approx(expected, rel=0.02)
    image = iio.imread(figure)
    assert image.shape[0] > 300 and image.shape[1] > 1000


def test_figure_of_a_pair_is_a_png(capsys, files, tmp_path):
    figure = tmp_path / "f.png"
    status, _, _ = run(capsys, files["a1"], files["a2"], "--figure", figure)
    assert status == 0 and iio.imread(figure).ndim == 3


def test_low_snr_warns_about_the_rician_bias(capsys, tmp_path):
    # SNR ~ 3 (signal 1000, sigma 300): a warning on stderr, the results still printed.
    np.save(tmp_path / "l1.npy", phantom(300, 5)[0])
    np.save(tmp_path / "l2.npy", phantom(300, 6)[0])
    status, _, err = run(capsys, tmp_path / "l1.npy", tmp_path / "l2.npy", "--roi", "central-box:60")
    assert status == 0
    assert err.startswith("dacm snr: warning: [rician_bias] SNR") and "Rician" in err


def _bad_inputs(tmp_path, files):
    base = phantom(10, 1)[0]
    np.save(tmp_path / "other_shape.npy", base[:, :-1])
    nan = base.copy()
    nan[5, 5] = np.nan
    np.save(tmp_path / "nan.npy", nan)
    np.save(tmp_path / "huge_a.npy", 1e305 * (1 + 0.01 * phantom(10, 1)[0]))
    np.save(tmp_path / "huge_b.npy", 1e305 * (1 + 0.01 * phantom(10, 2)[0]))
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "x.txt").write_text("no images")
    return {
        "mismatched shapes": ([files["a1"], tmp_path / "other_shape.npy"], "shapes differ"),
        "folder with no images": ([tmp_path / "empty", files["a1"]], "no DICOM image"),
        "NaN pixels": ([files["a1"], tmp_path / "nan.npy"], "NaN"),
        "values near 1e305": ([tmp_path / "huge_a.npy", tmp_path / "huge_b.npy"], "overflow float64"),
        "identical images": ([files["a1"], files["a1"]], "zero noise"),
        "ROI outside": ([files["a1"], files["a2"], "--roi", "box:250:250:20:20"], "outside"),
        "empty ROI": ([files["a1"], files["a2"], "--roi", "central-circle:1"], "holds 0 pixel"),
        "bad ROI text": ([files["a1"], files["a2"], "--roi", "box:1:2"], "ROW:COL"),
        "mm without spacing": ([files["a1"], files["a2"], "--roi", "central-box:20mm"], "in mm"),
        "pair method on one image": ([files["a1"], "--method", "nema"], "needs two images"),
        "three images": ([files["a1"], files["a2"], files["b1"]], "expected one image A or a pair"),
        "figure not an image": ([files["a1"], files["a2"], "--figure", tmp_path / "f.txt"],
                                "must end in .png"),
        "bad acquisition override": ([files["a1"], files["a2"], "--acquisition", "averages"],
                                     "expected FIELD=NUMBER"),
        "unknown acquisition field": ([files["a1"], files["a2"], "--acquisition", "tr=3"],
                                      "normalisation field 'tr' unknown"),
        "negative override": ([files["a1"], files["a2"], "--acquisition", "averages=-1"],
                              "averages = -1.0: must be a positive finite number"),
        "kernel": ([files["a1"], "--kernel", "1"], "kernel_px = 1"),
        "condition without reference": (
            [files["a1"], files["a2"], "--condition", "x", files["b1"], files["b2"]],
            "needs --reference",
        ),
        "reference without condition": (["--reference", files["a1"], files["a2"]], "at least one"),
        "missing file": ([tmp_path / "nope.dcm", files["a1"]], "no such file"),
        "figure slice": ([files["a1"], files["a2"], "--figure", tmp_path / "f.png",
                          "--figure-slice", "4"], "outside 0..0"),
        "figure folder": ([files["a1"], files["a2"], "--figure", tmp_path / "no" / "f.png"],
                          "does not exist"),
    }


@pytest.mark.parametrize(
    "case",
    ["mismatched shapes", "folder with no images", "NaN pixels", "values near 1e305", "identical images", "ROI outside",
     "empty ROI", "bad ROI text", "mm without spacing", "pair method on one image", "three images",
     "figure not an image", "bad acquisition override", "unknown acquisition field",
     "negative override", "kernel", "condition without reference",
     "reference without condition", "missing file", "figure slice", "figure folder"],
)
def test_bad_input_exits_2_with_one_line(capsys, tmp_path, files, case):
    args, message = _bad_inputs(tmp_path, files)[case]
    status, out, err = run(capsys, *args)
    assert status == 2
    assert out == ""
    assert err.startswith("dacm snr: error: ") and err.count("\n") == 1
    assert message in err
    assert not (tmp_path / "f.png").exists() and not (tmp_path / "f.txt").exists()


def test_mask_file_roi(capsys, files, tmp_path):
    mask = np.zeros((SIZE, SIZE), dtype=np.uint8)
    mask[100:140, 110:150] = 1
    iio.imwrite(tmp_path / "mask.png", mask * 255)
    status, out, _ = run(capsys, files["a1"], files["a2"], "--roi", f"mask:{tmp_path / 'mask.png'}",
                         "--json")
    assert status == 0
    rois = json.loads(out)["slices"][0]["methods"][0]["rois"]
    assert rois[0]["n_pixels"] == 1600
