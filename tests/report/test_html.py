"""The shared report helpers: figures as data URIs, file records, templates, atomic pages."""

import base64
import xml.etree.ElementTree as ET

import imageio.v3 as iio
import jinja2
import pytest
from matplotlib.figure import Figure

from sensor.report import html as rh
from sensor.report.design_report import Verification


def _decode(uri: str, mime: str) -> bytes:
    head, data = uri.split(",", 1)
    assert head == f"data:{mime};base64"
    return base64.b64decode(data, validate=True)


def _figure() -> Figure:
    fig = Figure(figsize=(2.0, 1.0))
    fig.subplots().plot([0, 1], [0, 1])
    return fig


def test_png_figure_has_the_size_asked_for():
    """A 2 x 1 inch figure at 110 dpi is a 220 x 110 px PNG with something drawn on it."""
    img = iio.imread(_decode(rh.figure_data_uri(_figure(), "png", dpi=110), "image/png"))
    assert img.shape[:2] == (110, 220)
    assert img.std() > 0


def test_svg_figure_is_well_formed_and_self_contained():
    """The SVG parses as XML, is 2 x 1 inch (144 x 72 pt), and every reference in it (href,
    xlink:href: glyphs, markers, clip paths) points inside the document."""
    root = ET.fromstring(_decode(rh.figure_data_uri(_figure(), "svg"), "image/svg+xml"))
    assert root.tag.endswith("svg")
    assert (root.get("width"), root.get("height")) == ("144pt", "72pt")
    refs = [v for el in root.iter() for k, v in el.attrib.items() if k.endswith("href")]
    assert refs and all(r.startswith("#") for r in refs), refs


def test_unknown_picture_kinds_are_refused():
    with pytest.raises(ValueError, match="kind = 'gif'"):
        rh.image_data_uri(b"GIF89a", "gif")
    with pytest.raises(ValueError, match="kind = 'jpeg'"):
        rh.figure_data_uri(_figure(), "jpeg")


def test_file_record_against_the_fips_180_2_test_vector(tmp_path):
    """SHA-256("abc") is the published test vector of FIPS 180-2 (appendix B.1)."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "x.bin").write_bytes(b"abc")
    rec = rh.file_record(tmp_path / "sub" / "x.bin", tmp_path)
    assert rec == rh.FileRecord("sub/x.bin", 3,
                                "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad")


def test_templates_escape_text_and_refuse_undefined_names():
    page = rh.render_template("verification.html.j2", verification=Verification("not run", "<b>x</b>"),
                              verify_limits={})
    assert "&lt;b&gt;x&lt;/b&gt;" in page and "<b>x</b>" not in page
    with pytest.raises(jinja2.UndefinedError):
        rh.render_template("verification.html.j2")


def test_write_html_replaces_only_when_forced(tmp_path):
    page = tmp_path / "r.html"
    page.write_text("old")
    with pytest.raises(FileExistsError, match="r.html exists"):
        rh.write_html("new", page)
    assert page.read_text() == "old"
    rh.write_html("<html>new</html>", page, force=True)
    assert page.read_text() == "<html>new</html>"
    assert [p.name for p in tmp_path.iterdir()] == ["r.html"]   # no temporary left behind


def test_software_versions_names_a_missing_library(monkeypatch):
    monkeypatch.setattr(rh, "REPORTED_LIBRARIES", ("numpy", "no-such-library-dacm"))
    v = rh.software_versions()
    assert v["no-such-library-dacm"] == "not installed"
    assert v["numpy"] == __import__("numpy").__version__
