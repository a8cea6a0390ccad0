"""The design report: states what the tool computes, lists the files it wrote with their true
checksums, is self-contained, and opens cleanly in a real browser."""

import base64
import hashlib
import sys
import time
import xml.etree.ElementTree as ET
from types import SimpleNamespace

import imageio.v3 as iio
import numpy as np
import pytest

from geometry.params import load_design, preset
from geometry.topology import build_beam_model
from sensor.errors import SensorInputError
from sensor.mechanics.qualifiers import qualify
from sensor.mechanics.solver import solve
from sensor.readout.datasheet import datasheet
from sensor.readout.sensor_model import build_sensor
from sensor.report.design_report import (
    VERIFY_LIMITS_PCT,
    continuum_verification,
    key_rows,
    output_paths,
    verification_from_dict,
    write_design_report,
)
from sensor.report.html import render_template
from tests.report.browser import open_in_browser, start_tags


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    design = preset("sample-b")
    return design, out, write_design_report(design, out, verify=False,
                                            command="dacm report --preset sample-b")



def test_numbers_are_those_of_the_solver_and_the_datasheet(report):
    """The summary and the page state what solve/qualify and the datasheet give when called
    directly (same deterministic computation: equal to the last bit)."""
    design, _, rep = report
    q = qualify(solve(build_beam_model(design), target_output_mm=1.0))
    ds = datasheet(build_sensor(design), material="delrin")
    s = rep.summary
    for name in ("amplification", "k_out_N_per_mm", "strain_energy_mJ", "hysteresis", "range_N",
                 "quality_mm_per_N"):
        assert s["solve"][name] == getattr(q, name), name
    assert s["datasheet"]["sensitivity_mV_per_N"] == ds.sensitivity_mV_per_N
    page = rep.path.read_text()
    for text in (f"{q.amplification:.4f}", f"{q.k_out_N_per_mm:.4f}", f"{100 * q.hysteresis:.3f}",
                 f"{ds.sensitivity_mV_per_N:.2f}", f"{ds.nonlinearity_pct:.2f}"):
        assert f'<td class="num">{text}</td>' in page, text


def test_rules_stresses_one_hysteresis_versions_and_commit(report):
    """The feasibility rules with their margins (as check_design gives them), every hinge's
    peak stress against the allowable (as hinge_stresses gives it), one hysteresis number
    (the predicted H, nowhere the datasheet's H of the volts), the versions of the libraries
    that computed numbers, and the git commit (the tests run from a checkout)."""
    from geometry.checks import check_design
    from geometry.provenance import git_commit
    from sensor.mechanics.stress import hinge_stresses

    design, _, rep = report
    page, s = rep.path.read_text(), rep.summary
    for rule in check_design(design).results:
        assert f"<td>{rule.rule}</td>" in page
        if rule.margin == rule.margin:  # not NaN
            assert f"{rule.margin:+.3f} {rule.unit}" in page, rule.rule
    model = build_beam_model(design)
    stresses = hinge_stresses(model, solve(model, target_output_mm=1.0))
    assert s["hinge_peak_stress_MPa"] == {str(h): v.peak_MPa for h, v in stresses.items()}
    assert s["allowable_stress_MPa"] == 36.0
    for v in stresses.values():
        assert f'<td class="num">{v.peak_MPa:.1f}</td>' in page
    worst = max(v.peak_MPa for v in stresses.values())
    assert f"{100 * worst / 36:.0f}</td>" in page  # the most stressed hinge, % of 36 MPa
    h = 100 * s["solve"]["hysteresis"]
    assert f"{h:.2f}" in page and f"{s['datasheet']['hysteresis_pct']:.2f}" not in page
    assert page.count("hysteresis H (predicted)") == 3   # key figure, solve table, datasheet
    for lib in ("gmsh", "scikit-fem", "numba", "cadquery-ocp", "ezdxf"):
        assert f"<td>{lib}</td>" in page
    commit = git_commit()
    assert commit and s["software"]["dacm git commit"] == commit and commit in page


def test_files_are_listed_with_their_true_size_and_sha256(report):
    design, out, rep = report
    assert {f.name for f in rep.files} == {f"sample-b.{x}" for x in ("dxf", "stl", "step", "json", "toml")}
    page = rep.path.read_text()
    for f in rep.files:
        data = (out / f.name).read_bytes()
        assert (f.size_bytes, f.sha256) == (len(data), hashlib.sha256(data).hexdigest())
        assert f.sha256 in page and f"{f.size_bytes:,}" in page
    assert load_design(out / "sample-b.toml") == design     # the inputs read back
    assert sorted(p.name for p in out.iterdir()) == sorted(p.name for p in output_paths(design, out))


def test_page_is_self_contained_with_every_picture_readable(report):
    """Nothing but inline style and data: images; every anchor link lands on a section, every
    other link downloads the SVG of the figure it sits under; the seven pictures decode (PNG
    not blank, SVG well-formed)."""
    _, _, rep = report
    tags = start_tags(rep.path.read_text())
    names = {t for t, _ in tags}
    assert not names & {"script", "link", "iframe", "object", "embed", "base"}
    ids = {a["id"] for _, a in tags if "id" in a}
    hrefs = [a["href"] for t, a in tags if "href" in a and "download" not in a]
    assert hrefs and all(h.startswith("#") and h[1:] in ids for h in hrefs), hrefs
    srcs = [a["src"] for t, a in tags if t == "img"]
    assert len(srcs) == 7
    downloads = {a["download"]: a["href"] for t, a in tags if "download" in a}
    assert sorted(downloads) == [f"sample-b-{n}.svg" for n in ("calibration", "hinge-stress", "intensity", "profile")]
    assert set(downloads.values()) <= set(srcs)
    for src in srcs:
        head, data = src.split(",", 1)
        raw = base64.b64decode(data, validate=True)
        if head == "data:image/png;base64":
            assert iio.imread(raw).std() > 0
        else:
            assert head == "data:image/svg+xml;base64"
            assert ET.fromstring(raw).tag.endswith("svg")


def test_page_opens_in_a_real_browser(report, tmp_path):
    """Headless chromium: a picture that is not blank, no console message at all (the page
    has no script; a blocked or failed load would log one), every image loaded."""
    _, _, rep = report
    start = time.perf_counter()
    seen = open_in_browser(rep.path, tmp_path)
    elapsed = time.perf_counter() - start
    img = seen.screenshot[..., :3].astype(float)
    ink = np.mean(img.min(axis=2) < 200)            # fraction of pixels that are not paper
    assert 0.02 < ink < 0.9, ink
    assert seen.console == []
    assert len(seen.images) == 7
    for complete, width, height, src in seen.images:
        assert complete and width > 0 and height > 0, src
    assert elapsed < 20, f"browser check took {elapsed:.1f} s"


def test_the_browser_check_sees_a_broken_and_a_blocked_image(report, tmp_path):
    """The same check on a spoiled copy: a corrupt embedded PNG loads with width 0, and an
    image from the network is blocked by the page's policy with a console message."""
    _, _, rep = report
    text = rep.path.read_text()
    first = text.index('src="data:image/')
    end = text.index('"', first + 5)
    spoiled = (text[:first] + 'src="data:image/png;base64,AAAA' + text[end:]).replace(
        "</main>", '<img src="https://example.invalid/x.png" alt="remote"></main>')
    page = tmp_path / "spoiled.html"
    page.write_text(spoiled)
    seen = open_in_browser(page, tmp_path / "browser")
    widths = [w for _, w, _, _ in seen.images]
    assert len(widths) == 8 and widths[0] == 0 and widths[-1] == 0 and all(widths[1:7])
    assert any("example.invalid" in line and "Content Security Policy" in line
               for line in seen.console), seen.console


def test_verification_not_run_says_why(report, monkeypatch):
    _, _, rep = report
    assert rep.summary["verification"] == {"status": "not run",
                                           "reason": "not requested (--no-verify)"}
    assert "Not run:</b> not requested (--no-verify)." in rep.path.read_text()
    monkeypatch.setitem(sys.modules, "sensor.mechanics.continuum", None)   # a tool without FE
    v = continuum_verification(preset("sample-b"), 1.0)
    assert v.status == "not run" and "no continuum model" in v.reason


def _verification_dict(err_a, err_k):
    """A dict in the schema of ``verification_to_dict`` (sensor.mechanics.continuum)."""
    fe = {"amplification": 4.0, "k_out_N_per_mm": 5.0, "strain_energy_mJ": 0.6,
          "hinge_stress_MPa": {"1": 7.81, "9": 21.9}}
    beam = {"amplification": 4.0 * (1 + err_a / 100), "k_out_N_per_mm": 5.0 * (1 + err_k / 100),
            "strain_energy_mJ": 0.61, "hinge_stress_MPa": {"1": 7.78, "9": 22.3},
            "hinge_peak_stress_MPa": {"1": 12.3, "9": 34.7}}
    errors = {k: 100 * (beam[k] / fe[k] - 1) for k in ("amplification", "k_out_N_per_mm", "strain_energy_mJ")}
    errors["hinge_stress_MPa"] = {h: 100 * (beam["hinge_stress_MPa"][h] / v - 1)
                                  for h, v in fe["hinge_stress_MPa"].items()}
    return {"design": "x", "fe": fe, "beam": beam, "errors_pct": errors,
            "convergence": {k: {"error_pct": 0.1} for k in errors if k != "hinge_stress_MPa"},
            "mesh": {"elements": 1000, "elements_across_hinge": 6.0},
            "options": {"plane_strain": False, "nonlinear": False, "output_travel_mm": 1.0}}


def test_verification_verdicts_use_the_design_limits():
    """|error| within DESIGN section 14's limit (1.5 % A, 3 % k_out) agrees, beyond it
    disagrees; strain energy has no limit and no verdict."""
    assert VERIFY_LIMITS_PCT == {"amplification": 1.5, "k_out_N_per_mm": 3.0}
    v = verification_from_dict(_verification_dict(err_a=-1.4, err_k=3.2))
    assert [r.verdict for r in v.rows] == ["agrees", "disagrees", ""]
    assert [r.error_pct for r in v.rows] == ["-1.40", "+3.20", "+1.67"]
    page = render_template("verification.html.j2", verification=v, verify_limits=VERIFY_LIMITS_PCT)
    assert '<td class="disagrees">disagrees</td>' in page
    assert "|error| ≤ 1.5 % on A" in page and "plane stress, linear" in page
    assert [(h.hinge, h.fe_MPa, h.beam_MPa) for h in v.hinge_rows] == [("1", "7.81", "7.78"),
                                                                       ("9", "21.90", "22.30")]
    q = SimpleNamespace(range_N=1.0, amplification=2.0, hysteresis=0.01)
    ds = SimpleNamespace(sensitivity_mV_per_N=1.0, resolution_N=1e-3, hysteresis_pct=1.0)
    assert key_rows(q, ds, v)[-1].value == "disagrees"
    assert key_rows(q, ds, verification_from_dict(_verification_dict(1.49, -2.99)))[-1].value == "agrees"


def test_nothing_is_written_over_an_existing_file_without_force(tmp_path):
    page = tmp_path / "sample-b-report.html"
    page.write_text("mine")
    with pytest.raises(FileExistsError, match="sample-b-report.html exists"):
        write_design_report(preset("sample-b"), tmp_path, verify=False)
    assert [p.name for p in tmp_path.iterdir()] == [page.name] and page.read_text() == "mine"


def test_bad_target_travel_is_refused(tmp_path):
    with pytest.raises(SensorInputError, match="target_output_mm = 0"):
        write_design_report(preset("sample-b"), tmp_path, target_output_mm=0)
    assert not any(tmp_path.iterdir())
