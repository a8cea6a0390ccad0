"""The MRI report (``dacm snr ... --report OUT.html``): one self-contained HTML page for a
pair, one image, or a reference-vs-condition comparison.

What it holds, each from the measuring code itself (nothing is re-derived here):

1. key figures: each method's SNR (and normalised SNR), the thesis' difference;
2. the figure of :mod:`mri.figure` (a, b and a - b with every ROI drawn);
3. the difference image explained: the shift and gain of b against a fitted to a - b
   (:mod:`mri.registration`), which is what makes a ring at a phantom's edge;
4. the per-ROI table of every method (per slice for a volume, with skipped slices and why);
5. the header checks: the protocol fields of each image side by side, and every quality
   warning with its code and numbers (:mod:`mri.quality`);
6. method notes (with how the 95 % intervals are made) and the inputs (the command, each
   file with its SHA-256 and acquisition time, the versions of what ran).
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
            "in the ROI; five 20 x 20 px boxes on the fitted phantom centre by default (brought "
            "in, then made smaller, when they do not fit the phantom, with a warning); the "
            "slice's SNR is the mean of the boxes' SNRs.",
    "smoothed": "McCann et al. 2013 smoothed subtraction (one image): Noise = std of the image "
                "minus its 9 x 9 boxcar mean in the ROI, as published (reads white noise "
                "0.62 % low); measured on each image of a pair.",
    "background": "NEMA MS 1 single-image method: Noise = std of air in four corner boxes / "
                  "0.655 (Rayleigh); valid for single-channel magnitude noise only (array "
                  "coils, prescan normalisation and parallel imaging change the air noise).",
}


#: Libraries whose versions the MRI report records (what loads, measures and draws).
MRI_LIBRARIES = ("numpy", "scipy", "pydicom", "nibabel", "scikit-image", "matplotlib", "jinja2")

INTERVAL_NOTE = (
    "Each SNR carries a 95 % interval for the sampling error of its noise estimate: a noise "
    "sigma estimated with nu degrees of freedom has the relative standard error 1 / sqrt(2 nu) "
    "(delta method on its chi-square distribution), and so has the SNR; nu = n - 1 for the "
    "NEMA and smoothed methods over n pixels, 2/3 of the neighbour pairs for the thesis "
    "method (consecutive differences share a pixel), 2 n / 2.245 for the background method "
    "(Rayleigh air). Several ROIs' errors add in quadrature, and so do slices'; the interval is "
    "the mean +- 1.96 standard errors. It covers noise only, not the ROI placement or the "
    "artefacts the warnings flag.")


def _fmt(value, spec=".2f") -> str:
    return "-" if value is None else format(value, spec)


def _key_rows(pair) -> list[Quantity]:
    rows = [Quantity(f"SNR {s.method}", _fmt(s.snr), "",
                     f"95 % interval {s.snr_ci95[0]:.1f} to {s.snr_ci95[1]:.1f}")
            for s in pair.result.summaries]
    if pair.result.normalisation_factor is not None:
        rows += [Quantity(f"normalised {s.method}", _fmt(s.snr_normalised, ".0f"), "")
                 for s in pair.result.summaries[:2]]
    if pair.result.difference_percent is not None:
        rows.append(Quantity("difference", _fmt(pair.result.difference_percent, ".3f"), "%"))
    return rows


def _text(value, spec=".6g") -> str:
    """A header value as the table shows it: numbers to 6 significant digits (``spec``)."""
    if value is None:
        return "-"
    if isinstance(value, (tuple, list)):
        return " x ".join(_text(v) for v in value) if all(isinstance(v, int) for v in value) else \
            ", ".join(_text(v, spec) for v in value)
    if isinstance(value, float):
        text = format(value, spec)
        return text.lstrip("-") if float(text) == 0 else text  # no "-0.0000"
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
        spec = ".4f" if name == "orientation" else ".6g"  # direction cosines: 4 decimals
        rows.append((name, _text(va, spec), "" if pair.b is None else _text(vb, spec), verdict))
    return rows


def _values_text(values: dict) -> str:
    """A warning's numbers as one line: ``name = value`` (4 significant digits), nested
    mappings (e.g. the outlier ROIs) flattened."""
    def one(value):
        if isinstance(value, float):
            return f"{value:.4g}"
        if isinstance(value, (list, tuple)):
            return ", ".join(one(v) for v in value)
        return str(value)

    return "; ".join(", ".join(f"{k2} = {one(v2)}" for k2, v2 in v.items()) if isinstance(v, dict)
                     else f"{k} = {one(v)}" for k, v in values.items())


def _inputs(pairs) -> list[tuple[str, str, str, str]]:
    """(role, file, acquired, SHA-256) of every input image, once each."""
    from mri.study import input_sha256

    seen, rows = set(), []
    for pair in pairs:
        for role, img in (("a", pair.a), ("b", pair.b)):
            if img is not None and img.source not in seen:
                seen.add(img.source)
                rows.append((f"{pair.name} {role}", img.source, img.acquisition.get("acquired") or "-",
                             input_sha256(img.source)))
    return rows


def _difference_note(pair, slice_index: int) -> str:
    """What a - b shows at the phantom's edge, from the fitted shift and gain: the text
    follows the numbers (a shift or gain over the limits of :mod:`mri.quality` is said to
    matter, and whether the ring reaches a signal ROI is measured)."""
    from scipy import ndimage

    from mri.phantom import find_phantom
    from mri.quality import MAX_GAIN_PERCENT, MAX_SHIFT_PX
    from mri.registration import fit_difference
    from mri.roi import resolve_roi

    a, b = pair.a.pixels[slice_index], pair.b.pixels[slice_index]
    try:
        mask, _ = find_phantom(a)
    except ValueError as exc:
        return f"No phantom found to analyse the difference image ({exc})."
    fit = fit_difference(a, b, mask)
    shift = max(abs(fit.shift_row_px), abs(fit.shift_col_px))
    text = (f"Fitted to a - b on slice {slice_index}: b is shifted by {fit.shift_row_px:+.3f} px "
            f"along rows and {fit.shift_col_px:+.3f} px along columns relative to a, and its "
            f"intensity differs by {100 * fit.gain:+.3f} %. On the phantom's edge a - b has an RMS "
            f"of {fit.edge_rms:.1f} (pixel units), {fit.edge_rms_after:.1f} once the shift and gain "
            f"are removed, against {fit.interior_rms:.1f} inside the phantom (noise x sqrt 2). ")
    if abs(100 * fit.gain) > MAX_GAIN_PERCENT:
        text += (f"A gain change of {100 * fit.gain:+.1f} % (limit {MAX_GAIN_PERCENT:g} %) leaves a "
                 "copy of the image in a - b: every subtraction SNR reads low. ")
    if shift > MAX_SHIFT_PX:
        return text + (
            f"A shift of {shift:.2f} px is over the {MAX_SHIFT_PX:g} px limit: the phantom moved "
            "(or the frequency drifted far) between the acquisitions. The edge in a - b is a "
            "misregistration, not noise, and so is whatever structure inside the phantom moved "
            "with it (ripples, texture): every ROI's noise is raised, not only the edge's. A "
            "first-order fit reads a shift this large only roughly.")
    text += ("The ring at the edge, bright on one side and dark on the opposite, is this "
             "sub-pixel misregistration acting on the steep edge (and on its Gibbs ripples, "
             "the same in both images otherwise). ")
    band = ndimage.binary_dilation(mask, iterations=2) & ~ndimage.binary_erosion(mask, iterations=2)
    reached = sorted({roi.label for specs in pair.specs.values() for spec in specs
                      for roi in resolve_roi(spec, a, pair.a.pixel_spacing_mm, slice_index)
                      if roi.label != "whole" and (roi.mask & band).any()})
    text += (f"The edge band (the 2 px on each side of the edge) reaches the ROI(s) "
             f"{', '.join(reached)}, whose noise it raises." if reached else
             "No signal ROI but the whole image reaches the edge band (the 2 px on each side of "
             "the edge), so the ring enters only a whole-image noise.")
    bandwidth = pair.a.acquisition.get("pixel_bandwidth_hz")
    if isinstance(bandwidth, float):
        text += (f" At {bandwidth:g} Hz/pixel, a shift of {shift:.3f} px along the readout is a "
                 f"resonance-frequency drift of about {shift * bandwidth:.1f} Hz.")
    return text


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
        command=command, versions=software_versions(MRI_LIBRARIES), inputs=_inputs(pairs),
        interval_note=INTERVAL_NOTE, values_text=_values_text,
        generated=datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        sections=[("results", "Results"), ("figure", "Images and ROIs"),
                  ("difference", "The difference image"), ("rois", "Per-ROI measures"),
                  ("checks", "Header checks and quality warnings"), ("methods", "Methods"),
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


def write_snr_outputs(csv_path, figure_path, report_path, pairs, panels, comparison=None,
                      command: str = "dacm snr") -> None:
    """Write the given ones of a CSV of the measured pairs, the figure of their panels and the
    HTML report as one set: each to a temporary file beside its name, all moved into place
    only when every one is complete (:func:`geometry.atomic.atomic_path`)."""
    from contextlib import ExitStack

    from geometry.atomic import atomic_path, save_figure
    from mri.figure import pair_figure
    from mri.study import write_csv

    with ExitStack() as stack:
        tmp = {key: stack.enter_context(atomic_path(path)) for key, path in
               (("csv", csv_path), ("figure", figure_path), ("report", report_path)) if path}
        if csv_path:
            write_csv(tmp["csv"], pairs)
        if figure_path:
            save_figure(pair_figure(panels), tmp["figure"])
        if report_path:
            write_snr_report(tmp["report"], pairs, panels, comparison, command)
