"""The MRI report (``dacm snr ... --report``): states the numbers the command prints, explains
the difference image, is self-contained, and opens cleanly in a real browser."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from sensor.cli import main
from tests.report.browser import open_in_browser, start_tags

PAIR = Path(__file__).resolve().parents[1] / "data" / "mri" / "siemens_aera_pair"
A, B = PAIR / "tra_250_2meas_1.IMA", PAIR / "tra_250_2meas_2.IMA"



@pytest.fixture(scope="module")
def pair_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("snr-report")
    page = out / "pair.html"
    assert main(["snr", str(A), str(B), "--report", str(page)]) == 0
    return page


def test_pair_report_states_the_printed_numbers(pair_report, capsys):
    assert main(["snr", str(A), str(B), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    page = pair_report.read_text()
    for s in result["summaries"]:
        assert f'<td class="num">{s["snr"]:.2f}</td>' in page, s["method"]
        assert f'<td class="num">{s["snr_normalised"]:.1f}</td>' in page, s["method"]
    for r in result["slices"][0]["methods"][1]["rois"]:
        assert f'<td>{r["roi"]}</td>' in page
    assert f'{result["difference_percent"]:.3f} %' in page
    assert "tra_250_2meas_1.IMA" in page and "SIEMENS Aera" in page


def test_pair_report_explains_the_ring_of_the_difference_image(pair_report):
    # The fitted shift of b against a on the real pair is ~0.04 px along rows (the readout
    # direction: the phase is encoded along the rows, InPlanePhaseEncodingDirection ROW).
    page = pair_report.read_text()
    shift = float(re.search(r"b is shifted by ([+-][0-9.]+) px along rows", page).group(1))
    assert 0.02 < shift < 0.06
    # the text follows the fit: sub-pixel, under the limits, and the ring stays out of the
    # NEMA boxes (only the whole-image ROI reaches the edge band)
    assert "this sub-pixel misregistration" in page and "over the" not in page
    assert "No signal ROI but the whole image reaches the edge band" in page


def test_pair_report_records_inputs_versions_intervals_and_orientation(pair_report, capsys):
    import hashlib

    assert main(["snr", str(A), str(B), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    page = pair_report.read_text()
    for path in (A, B):
        assert hashlib.sha256(path.read_bytes()).hexdigest() in page
    assert result["a"]["sha256"] == hashlib.sha256(A.read_bytes()).hexdigest()
    assert re.search(r"<td>20\d\d-\d\d-\d\dT\d\d:\d\d", page)  # acquisition date and time
    for library in ("pydicom", "numpy", "scikit-image"):
        assert f"<td>{library}</td>" in page
    assert "<td>cadquery</td>" not in page
    for s in result["summaries"]:
        low, high = s["snr_ci95"]
        assert low < s["snr"] < high
        assert f'{low:.2f} to {high:.2f}' in page
    cosines = re.search(r"<td>orientation</td><td>([^<]*)</td>", page).group(1)
    assert re.fullmatch(r"(-?\d\.\d{4}, ){5}-?\d\.\d{4}", cosines), cosines
    assert "white-space: pre-wrap" in page  # the command wraps
    assert "No warnings: every check passed." in page


def test_report_lists_every_warning_with_its_numbers(tmp_path, capsys):
    from mri.io import load_image

    a, b = load_image(A), load_image(B)
    np.save(tmp_path / "a.npy", a.pixels)
    np.save(tmp_path / "b.npy", np.roll(b.pixels, 3, axis=1))
    page = tmp_path / "r.html"
    assert main(["snr", str(tmp_path / "a.npy"), str(tmp_path / "b.npy"), "--report", str(page)]) == 0
    err = capsys.readouterr().err
    text = page.read_text()
    assert "[misregistration]" in err and "<code>misregistration</code>" in text
    assert re.search(r"shift_row_px = [0-9.]+; shift_col_px = -?[0-9.]+; limit_px = 0.3", text)
    assert "is over the 0.3 px limit" in text  # the difference note follows the fit


def test_pair_report_is_self_contained(pair_report):
    tags = start_tags(pair_report.read_text())
    for tag, attrs in tags:
        for key in ("src", "href"):
            value = attrs.get(key, "")
            assert not value or value.startswith(("data:", "#")), (tag, value)
    assert sum(tag == "img" for tag, _ in tags) == 1


def test_existing_report_is_kept_unless_forced(tmp_path):
    from sensor.report.snr_report import write_snr_report

    page = tmp_path / "r.html"
    page.write_text("mine")
    with pytest.raises(FileExistsError):
        write_snr_report(page, [], [], force=False)
    assert page.read_text() == "mine"


@pytest.fixture(scope="module")
def comparison_report(tmp_path_factory):
    from tests.mri.phantoms import noisy_pair, phantom

    out = tmp_path_factory.mktemp("snr-comparison")
    truth = phantom()
    for name, sigma, seed in (("a", 10.0, 1), ("b", 20.0, 2)):
        for k, image in enumerate(noisy_pair(truth, sigma, seed)):
            np.save(out / f"{name}{k}.npy", image)
    page = out / "comparison.html"
    assert main(["snr", "--reference", str(out / "a0.npy"), str(out / "a1.npy"), "--condition",
                 "sensor", str(out / "b0.npy"), str(out / "b1.npy"), "--report", str(page)]) == 0
    return page


def test_comparison_report_has_the_condition_table(comparison_report):
    page = comparison_report.read_text()
    assert "MRI compatibility report" in page and "<td>sensor</td>" in page
    changes = [float(v) for v in re.findall(r'<td class="num">([+-][0-9.]+)</td>', page)]
    assert changes and all(-55 < c < -45 for c in changes)  # SNR halved: sigma 10 -> 20


@pytest.mark.parametrize("which", ["pair_report", "comparison_report"])
def test_reports_open_in_a_real_browser(which, request, tmp_path):
    """Headless chromium: the screenshot is not blank, the console is silent (the page has
    no script; a blocked or failed load would log one), every image loaded."""
    seen = open_in_browser(request.getfixturevalue(which), tmp_path)
    img = seen.screenshot[..., :3].astype(float)
    ink = np.mean(img.min(axis=2) < 200)
    assert 0.02 < ink < 0.9, ink
    assert seen.console == []
    assert len(seen.images) == 1
    for complete, width, height, src in seen.images:
        assert complete and width > 0 and height > 0, src
