"""The MRI report (``dacm snr ... --report OUT.html``): one self-contained HTML page for a
pair, one image, or a reference-vs-condition comparison.

What it holds, each from the measuring code itself (nothing is re-derived here):

1. key figures: each method's SNR (and normalised SNR), the thesis' difference;
2. the figure of :mod:`mri.figure` (a, b and a - b with every ROI drawn);
3. the difference image explained: the shift and gain of b against a fitted to a - b
   (:mod:`mri.registration`), which is what makes a ring at a phantom's edge;
4. the per-ROI table of every method (per slice for a volume, with skipped slices and why);
5. the header checks: the protocol fields of each image side by side, and the warnings;
6. method notes and the inputs (command, files, software versions).
"""

from __future__ import annotations

import datetime
from pathlib import Path

from sensor.report.html import (
    EmbeddedFigure,
    Quantity,
    figure_data_uri,
    render_template,
    software_versions,
    write_html,
)

METHOD_NOTES = {
    "thesis": "Thesis eqs 91-93: noise from horizontal neighbour differences of a - b, "
              "SD^2 = sum (V(i,j+1) - V(i,j))^2 / (2 n (m-1)), Noise = SD / sqrt 2; signal the "
              "mean of a (the whole image by default, background included).",
    "nema": "NEMA MS 1 subtraction: Noise = std(a - b in the ROI) / sqrt 2, Signal = mean of a "
            "in the ROI; five 20 x 20 px boxes on the fitted phantom centre by default; the "
            "slice's SNR is the mean of the boxes' SNRs.",
    "smoothed": "McCann et al. 2013 smoothed subtraction (one image): Noise = std of the image "
                "minus its 9 x 9 boxcar mean in the ROI, as published (reads white noise "
                "0.62 % low); measured on each image of a pair.",
    "background": "NEMA MS 1 single-image method: Noise = std of air in four corner boxes / "
                  "0.655 (Rayleigh); valid for single-channel magnitude noise only (array "
                  "coils, prescan normalisation and parallel imaging change the air noise).",
}


def _fmt(value, spec=".2f") -> str:
    return "-" if value is None else format(value, spec)


def _key_rows(pair) -> list[Quantity]:
    rows = [Quantity(f"SNR {s.method}", _fmt(s.snr), "") for s in pair.result.summaries]
    if pair.result.normalisation_factor is not None:
        rows += [Quantity(f"normalised {s.method}", _fmt(s.snr_normalised, ".0f"), "")
                 for s in pair.result.summaries[:2]]
    if pair.result.difference_percent is not None:
        rows.append(Quantity("difference", _fmt(pair.result.difference_percent, ".3f"), "%"))
    return rows


def _text(value) -> str:
    """A header value as the table shows it: numbers to 6 significant digits."""
    if value is None:
        return "-"
    if isinstance(value, (tuple, list)):
        return " x ".join(_text(v) for v in value) if all(isinstance(v, int) for v in value) else \
            ", ".join(_text(v) for v in value)
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _header_rows(pair) -> list[tuple[str, str, str, str]]:
    """(field, a, b, verdict) for the geometry and protocol fields."""
    from mri.io import DICOM_ACQUISITION_FIELDS, DICOM_DESCRIPTIVE_FIELDS

    def geometry(img):
        return {"shape (slices, rows, cols)": img.shape, "pixel spacing (mm)": img.pixel_spacing_mm,
                "slice thickness (mm)": img.slice_thickness_mm, "orientation": img.orientation,
                "position (mm)": img.position_mm, "scanner": img.scanner, "series": img.series}

    fields_a = {**geometry(pair.a), **pair.a.acquisition}
    fields_b = {} if pair.b is None else {**geometry(pair.b), **pair.b.acquisition}
    names = list(geometry(pair.a)) + list(DICOM_ACQUISITION_FIELDS) + list(DICOM_DESCRIPTIVE_FIELDS)
    rows = []
    for name in names:
        va, vb = fields_a.get(name), fields_b.get(name)
        if va is None and vb is None:
            continue
        verdict = "" if pair.b is None else ("same" if va == vb else "differs")
        rows.append((name, _text(va), "" if pair.b is None else _text(vb), verdict))
    return rows


def _difference_note(pair, slice_index: int) -> str:
    """What a - b shows at the phantom's edge, from the fitted shift and gain."""
    from mri.phantom import find_phantom
    from mri.registration import fit_difference

    a, b = pair.a.pixels[slice_index], pair.b.pixels[slice_index]
    try:
        mask, _ = find_phantom(a.astype(float))
    except ValueError as exc:
        return f"No phantom found to analyse the difference image ({exc})."
    fit = fit_difference(a, b, mask)
    bandwidth = pair.a.acquisition.get("pixel_bandwidth_hz")
    drift = (f" At {bandwidth:g} Hz/pixel, a shift of {max(abs(fit.shift_row_px), abs(fit.shift_col_px)):.3f} px "
             f"along the readout is a resonance-frequency drift of about "
             f"{max(abs(fit.shift_row_px), abs(fit.shift_col_px)) * bandwidth:.1f} Hz between the acquisitions."
             if isinstance(bandwidth, float) else "")
    return (
        f"Fitted to a - b on slice {slice_index}: b is shifted by {fit.shift_row_px:+.3f} px along "
        f"rows and {fit.shift_col_px:+.3f} px along columns relative to a, and its intensity "
        f"differs by {100 * fit.gain:+.3f} %. On the phantom's edge a - b has an RMS of "
        f"{fit.edge_rms:.1f} (pixel units), {fit.edge_rms_after:.1f} once the shift and gain are "
        f"removed, against {fit.interior_rms:.1f} inside the phantom (noise x sqrt 2). A ring at "
        "the edge that is bright on one side and dark on the opposite side is this sub-pixel "
        "misregistration acting on the steep edge (and on its Gibbs ripples, which are the same "
        "in both images and cancel otherwise); it is not noise, and it does not reach the "
        f"default ROIs, which lie well inside the edge.{drift}"
    )


def snr_report_context(pairs, panels, comparison, command: str) -> dict:
    """The template context (kept separate so that tests can check it)."""
    from mri.figure import pair_figure

    first = pairs[0]
    figure = EmbeddedFigure(
        figure_data_uri(pair_figure(panels), "png"),
        "Images a and b and their difference a - b, with the regions of interest outlined",
        "a and b share one grey scale (0 to the brightest pixel, nothing saturated); a - b on "
        "+-4 robust standard deviations, so the phantom's edge is clipped. Each ROI has one "
        "colour in every panel, listed with the methods that use it.",
    )
    notes = []
    for pair in pairs:
        if pair.b is not None:
            k = next((s.index for s in pair.result.slices if not s.skipped), 0)
            notes.append((pair.name, _difference_note(pair, k)))
    methods = list(dict.fromkeys(s.method for p in pairs for s in p.result.summaries))
    return dict(
        title="MRI compatibility report" if comparison else "MRI SNR report",
        subtitle=f"{first.a.source}" + ("" if first.b is None else f" and {first.b.source}"),
        pairs=pairs, key_rows=_key_rows(first), figure=figure, notes=notes,
        headers=[(p.name, _header_rows(p)) for p in pairs],
        comparison=comparison, method_notes=[(m, METHOD_NOTES[m]) for m in methods],
        command=command, versions=software_versions(),
        generated=datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        sections=[("results", "Results"), ("figure", "Images and ROIs"),
                  ("difference", "The difference image"), ("rois", "Per-ROI measures"),
                  ("checks", "Header checks and warnings"), ("methods", "Methods"),
                  ("inputs", "Inputs and software")],
    )


def write_snr_report(path, pairs, panels, comparison=None, command: str = "dacm snr",
                     force: bool = True):
    """Render and write the page atomically (replacing a file only with ``force``, checked
    before anything is computed)."""
    if Path(path).exists() and not force:
        raise FileExistsError(f"{path} exists (replace it with force)")
    context = snr_report_context(pairs, panels, comparison, command)
    return write_html(render_template("snr_report.html.j2", **context), path, force=force)
