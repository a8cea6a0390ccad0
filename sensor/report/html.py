"""Self-contained HTML reports: the part every report of the tool shares.

A report is one HTML file that opens anywhere, offline: figures are embedded as ``data:``
URIs, the style sheet is inline, and a Content-Security-Policy forbids every other source,
so the file neither loads nor sends anything. Pages are Jinja2 templates in
``sensor/report/templates`` (package data) extending ``base.html.j2``, which provides the
header, the style, a table of contents and the footer; ``macros.html.j2`` provides the
blocks reports are made of (a quantity table, a figure with its caption, a file list).

API (used by :mod:`sensor.report.design_report` and meant for any later report):

- :func:`figure_data_uri` -- a matplotlib ``Figure`` as a PNG or SVG ``data:`` URI;
- :func:`image_data_uri` -- bytes of a PNG/SVG/JPEG picture as a ``data:`` URI;
- :class:`Quantity` -- one table row: label, formatted value, unit, note;
- :class:`EmbeddedFigure` -- an embedded picture with alt text and caption;
- :class:`FileRecord` / :func:`file_record` -- a written file with its size and SHA-256;
- :func:`software_versions` -- the versions of the tool, Python and its main libraries;
- :func:`render_template` -- render a template of the package with a context;
- :func:`write_html` -- write the page atomically, replacing a file only when asked.
"""

from __future__ import annotations

import base64
import hashlib
import importlib.metadata
import io
import os
import platform
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from geometry.atomic import atomic_path

#: Image types a report may embed (suffix -> MIME type).
IMAGE_TYPES = {"png": "image/png", "svg": "image/svg+xml", "jpeg": "image/jpeg"}

#: The Content-Security-Policy of every report: nothing but the page itself, its inline
#: style and embedded images (no scripts, no fonts, no network).
CONTENT_SECURITY_POLICY = "default-src 'none'; img-src data:; style-src 'unsafe-inline'"

#: Libraries whose versions a report states beside the tool's own: every one that computes
#: a number or writes a file the reports show (solver, FE mesh and solve, CAD and its
#: kernel, DXF, mesh check, rendering, DICOM, figures, the page).
REPORTED_LIBRARIES = ("numpy", "scipy", "numba", "gmsh", "scikit-fem", "cadquery", "cadquery-ocp", "ezdxf",
                      "trimesh", "pyvista", "vtk", "scikit-image", "pydicom", "matplotlib", "jinja2")


@dataclass(frozen=True)
class Quantity:
    """One row of a results table: ``value`` already formatted (the report states numbers
    as the text output does), ``unit`` as printed ("" for a ratio), ``note`` optional."""

    label: str
    value: str
    unit: str = ""
    note: str = ""


@dataclass(frozen=True)
class EmbeddedFigure:
    """A picture in a report: ``src`` a ``data:`` URI, ``alt`` the text a screen reader
    says, ``caption`` what the reader should see in it; an SVG is offered for download as
    ``download`` (a file name) when given."""

    src: str
    alt: str
    caption: str
    download: str = ""


@dataclass(frozen=True)
class FileRecord:
    """A file the run wrote: its name (relative to the output folder), size and SHA-256."""

    name: str
    size_bytes: int
    sha256: str


def image_data_uri(data: bytes, kind: str) -> str:
    """A ``data:`` URI of picture bytes; ``kind`` is a key of :data:`IMAGE_TYPES`."""
    if kind not in IMAGE_TYPES:
        raise ValueError(f"kind = {kind!r}: must be one of {', '.join(IMAGE_TYPES)}")
    return f"data:{IMAGE_TYPES[kind]};base64,{base64.b64encode(data).decode('ascii')}"


def figure_data_uri(fig, kind: str = "svg", dpi: float | None = None) -> str:
    """A matplotlib ``Figure`` as a ``data:`` URI: ``svg`` (vector, text as paths so no
    font is needed) or ``png`` (``dpi`` pixels per inch)."""
    if kind not in ("svg", "png"):
        raise ValueError(f"kind = {kind!r}: a figure is embedded as svg or png")
    buf = io.BytesIO()
    metadata = {"Date": None} if kind == "svg" else {}
    fig.savefig(buf, format=kind, dpi=dpi, metadata=metadata)
    return image_data_uri(buf.getvalue(), kind)


def file_record(path: str | os.PathLike, root: str | os.PathLike) -> FileRecord:
    """The record of a written file, named relative to ``root``."""
    path = Path(path)
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    return FileRecord(path.relative_to(root).as_posix(), path.stat().st_size, digest)


def software_versions(libraries: tuple[str, ...] | None = None) -> dict[str, str]:
    """Versions of dacm (and its git commit when run from a checkout), Python, the platform
    and ``libraries`` (default :data:`REPORTED_LIBRARIES`; as installed, "not installed" for
    one that is absent)."""
    from geometry.provenance import git_commit, version

    out = {"dacm": version()}
    commit = git_commit()
    if commit:
        out["dacm git commit"] = commit
    out |= {"python": platform.python_version(), "platform": platform.platform()}
    for name in REPORTED_LIBRARIES if libraries is None else libraries:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


@cache
def _environment():
    import jinja2

    env = jinja2.Environment(loader=jinja2.PackageLoader("sensor.report", "templates"),
                             autoescape=True, undefined=jinja2.StrictUndefined,
                             trim_blocks=True, lstrip_blocks=True)
    env.globals["content_security_policy"] = CONTENT_SECURITY_POLICY
    return env


def render_template(name: str, **context) -> str:
    """Render ``templates/<name>`` with ``context`` (autoescaped; an undefined name is an
    error, never an empty string)."""
    return _environment().get_template(name).render(**context)


def write_html(text: str, path: str | os.PathLike, force: bool = False) -> Path:
    """Write the page at ``path`` atomically; an existing file is replaced only with
    ``force`` (otherwise ``FileExistsError`` naming it)."""
    path = Path(path)
    if path.exists() and not force:
        raise FileExistsError(f"{path} exists (replace it with force)")
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path
