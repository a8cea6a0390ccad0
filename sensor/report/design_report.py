"""The design report (``dacm report``): one self-contained HTML page per design.

What it holds, each computed by the tool's own functions (nothing is re-derived here):

1. the profile (:func:`geometry.drawing.profile_figure`, cf. thesis Figure 48) and the
   design's main parameters;
2. the solve to the target output travel (:func:`sensor.mechanics.solver.solve`) and its
   qualifiers (:func:`sensor.mechanics.qualifiers.qualify`: A, k_out, sensitivity, SE,
   predicted H, quality, range), with the hinge rotations; the feasibility rules it passed
   with their margins (:func:`geometry.checks.check_design`) and every hinge's peak stress
   at full scale against the allowable (:func:`sensor.mechanics.stress.hinge_stresses`);
3. the sensor datasheet (:func:`sensor.readout.datasheet.datasheet`, cross-axis ratio) with
   the calibration and intensity plots (:mod:`sensor.readout.plots`);
4. the deformed body in 3D (:mod:`sensor.mechanics.render`, off-screen);
5. the verification against the continuum model (``verify_design`` of
   ``sensor.mechanics.continuum``) with its stress field when that module is part of the
   installed tool, otherwise a line saying it was not run and why;
6. the files written beside it (:func:`geometry.export.export_design` and the design TOML
   of :func:`geometry.params.save_design`) with their sizes and SHA-256;
7. the inputs (the design TOML, the command line), the software versions of every library
   that computed a number and the git commit when run from a checkout;
8. the predicted MRI artefact (:func:`sensor.artefact.prediction.predict`): field offsets
   near the surface, spin-echo shift, gradient-echo artefact extent, two figures.

One hysteresis number throughout (:data:`HYSTERESIS_DEFINITION`): the predicted H of the
strain-energy law. Every matplotlib figure is embedded as SVG and offered for download.

Everything is computed before the first file is written, so a design that fails to solve,
read or render leaves nothing behind. Lengths mm, forces N, energies mJ.
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

from geometry.params import Design
from sensor.report.html import (
    EmbeddedFigure,
    FileRecord,
    Quantity,
    figure_data_uri,
    file_record,
    image_data_uri,
    render_template,
    software_versions,
    write_html,
)

#: DESIGN section 14: the beam model must agree with the converged continuum within these
#: limits (|beam / FE - 1|, %). Strain energy and hinge stresses are shown without a limit.
VERIFY_LIMITS_PCT = {"amplification": 1.5, "k_out_N_per_mm": 3.0}

#: Size (px) of the embedded 3D picture.
RENDER_WINDOW_PX = (1200, 900)

#: Nonlinearity tolerance (% FS) of the working range shaded on the intensity plot (as the
#: default of ``dacm sensor --tolerance``).
INTENSITY_TOLERANCE_PCT = 1.0

_CONTINUUM = "sensor.mechanics.continuum"

#: The one hysteresis number of the report and what it is.
HYSTERESIS_DEFINITION = (
    "H: the widest gap between the loading and unloading output travel at equal force over the "
    "full-scale travel (thesis eq 87), predicted from the strain energy at full scale by the "
    "strain-energy law H = c × SE")


@dataclass(frozen=True)
class RuleRow:
    """One feasibility rule as the report shows it (formatted): verdict, margin, message."""

    rule: str
    verdict: str
    margin: str
    message: str


@dataclass(frozen=True)
class PeakStressRow:
    """One hinge's peak stress at full scale against the allowable (formatted)."""

    hinge: str
    peak_MPa: str
    utilisation_pct: str
    verdict: str


@dataclass(frozen=True)
class ComparisonRow:
    """One quantity of the beam model against the continuum FE (formatted for the page);
    ``limit`` and ``verdict`` ("agrees" / "disagrees") are empty without a limit."""

    label: str
    unit: str
    fe: str
    beam: str
    error_pct: str
    fe_mesh_error_pct: str
    limit: str
    verdict: str


@dataclass(frozen=True)
class HingeStressRow:
    """One hinge's stress one thickness inside its neck, FE against beam, and the beam's
    peak at the root (MPa, formatted)."""

    hinge: str
    fe_MPa: str
    beam_MPa: str
    error_pct: str
    beam_peak_MPa: str


@dataclass(frozen=True)
class Verification:
    """The continuum check as the report shows it: ``status`` "run" or "not run" (with the
    ``reason``), and when run the comparison rows, a sentence on the method and the dict of
    ``verification_to_dict`` (``data``)."""

    status: str
    reason: str = ""
    rows: tuple[ComparisonRow, ...] = ()
    hinge_rows: tuple[HingeStressRow, ...] = ()
    method: str = ""
    data: dict | None = None
    figure: EmbeddedFigure | None = None


@dataclass(frozen=True)
class DesignReport:
    """A written design report: the page's path, the files beside it and the numbers it
    states as JSON (SI-style units in the key names, as ``dacm solve --json``)."""

    path: Path
    files: tuple[FileRecord, ...]
    summary: dict


# --- paths ---------------------------------------------------------------------------------

def report_path(design: Design, out_dir: str | Path) -> Path:
    """Where the page goes: ``<out_dir>/<design name>-report.html``."""
    return Path(out_dir) / f"{design.name}-report.html"


def output_paths(design: Design, out_dir: str | Path) -> list[Path]:
    """Every file a report writes: the export files, the design TOML and the page."""
    from geometry.export import FORMATS

    out = Path(out_dir)
    return ([out / f"{design.name}.{fmt}" for fmt in FORMATS] + [out / f"{design.name}.toml",
            report_path(design, out)])


# --- sections --------------------------------------------------------------------------------

def design_rows(design: Design) -> list[Quantity]:
    """The design's main parameters (the full set is the TOML in the inputs section)."""
    t = design.used_thickness_mm
    rows = [Quantity("side-link lean φ1", f"{design.phi1_deg:g}", "deg")]
    if not design.is_basis:
        rows.append(Quantity("middle-link rise φ2", f"{design.phi2_deg:g}", "deg"))
    return rows + [
        Quantity("hinge set", design.hinge_set, "",
                 f"hinges 1-{len(t)}: " + ", ".join(f"{v:g}" for v in t) + " mm"),
        Quantity("hinge length", f"{design.hinge_length_mm:g}", "mm"),
        Quantity("footprint w × h", f"{design.width_mm:g} × {design.height_mm:g}", "mm"),
        Quantity("sheet thickness", f"{design.sheet_thickness_mm:g}", "mm"),
        Quantity("fiber clearance at rest", f"{design.fiber_clearance_mm:g}", "mm"),
        Quantity("material", design.material.name, "",
                 f"E = {design.material.E_MPa:g} MPa, ν = {design.material.nu:g}"),
    ]


def solve_rows(result, qualifiers, a_kin: float, law) -> list[Quantity]:
    """The solve and its qualifiers, as ``dacm solve`` prints them."""
    r, q = result, qualifiers
    return [
        Quantity("amplification A", f"{q.amplification:.4f}", "",
                 f"kinematic A_kin {a_kin:.4f}"),
        Quantity("output stiffness k_out", f"{q.k_out_N_per_mm:.4f}", "N/mm"),
        Quantity("sensitivity", f"{q.sensitivity_mm_per_N:.4f}", "mm/N", "1 / k_out"),
        Quantity("range (input force at the target travel)", f"{q.range_N:.4f}", "N"),
        Quantity("strain energy SE", f"{q.strain_energy_mJ:.4f}", "mJ"),
        Quantity("hysteresis H (predicted)", f"{100 * q.hysteresis:.3f}", "% FS",
                 f"c = {law.h_per_mJ:.4f} per mJ, calibrated on the {law.calibrated_on} specimen"),
        Quantity("quality sensitivity / H", f"{q.quality_mm_per_N:.3f}", "mm/N",
                 "thesis Table 6 “SNR”"),
        Quantity("input travel", f"{r.input_travel_mm:.4f}", "mm"),
        Quantity("output travel", f"{r.output_travel_mm:.4f}", "mm"),
        Quantity("increments / residual", f"{r.increments} / {r.residual:.1e}", "",
                 "converged" if r.converged else "NOT converged"),
    ]


def datasheet_rows(ds, cross) -> list[Quantity]:
    """The datasheet, as ``dacm sensor`` prints it."""
    return [
        Quantity("range", f"0 – {ds.range_N:.3f}", "N",
                 f"mirror travel {ds.target_output_mm:g} mm, gap {ds.gap_max_mm:.2f} → "
                 f"{ds.gap_min_mm:.2f} mm"),
        Quantity("output span", f"{ds.span_V:.4f}", "V"),
        Quantity("sensitivity", f"{ds.sensitivity_mV_per_N:.2f}", "mV/N", "least-squares line"),
        Quantity("resolution", f"{ds.resolution_N * 1e3:.3f}", "mN RMS",
                 "worst over the range; noise and quantisation"),
        Quantity("noise", f"{ds.noise_rms_V * 1e6:.2f}", "µV RMS",
                 f"at {ds.sample_rate_Hz:g} S/s (bandwidth {ds.sample_rate_Hz / 2:g} Hz)"),
        Quantity("ADC", f"{ds.adc_bits}-bit, step {ds.adc_step_V * 1e6:.0f}", "µV"),
        Quantity("nonlinearity", f"{ds.nonlinearity_pct:.2f}", "% FS", "mean branch against the line"),
        Quantity("hysteresis H (predicted)", f"{ds.hysteresis_mechanical_pct:.3f}", "% FS",
                 f"as in section 2, from SE {ds.strain_energy_mJ:.3f} mJ"),
        Quantity("cross-axis", f"{cross.ratio_pct:.3f}", "%",
                 f"mirror travel under {cross.imposed_travel_mm:.3f} mm lateral vs axial input "
                 f"travel; tilt {cross.tilt_deg:+.2f}°; thesis 1.66 % (delrin)"),
    ]


def rule_rows(report) -> list[RuleRow]:
    """The feasibility rules of :func:`geometry.checks.check_design` with their margins."""
    return [RuleRow(r.rule, "pass" if r.ok else "FAIL",
                    f"{r.margin:+.3f} {r.unit}" if math.isfinite(r.margin) else "", r.message)
            for r in report.results]


def peak_stress_rows(stresses: dict, allowable_MPa: float) -> list[PeakStressRow]:
    """Each hinge's peak stress (root concentration included) against the allowable."""
    return [PeakStressRow(str(h), f"{s.peak_MPa:.1f}", f"{100 * s.peak_MPa / allowable_MPa:.0f}",
                          "within" if s.peak_MPa <= allowable_MPa else "OVER")
            for h, s in sorted(stresses.items())]


def svg_figure(fig, download: str, alt: str, caption: str) -> EmbeddedFigure:
    """A matplotlib figure embedded as SVG and offered for download as ``download``."""
    return EmbeddedFigure(figure_data_uri(fig), alt, caption, download)


def key_rows(q, ds, verification: Verification) -> list[Quantity]:
    """The few numbers a reader looks for first (details in the sections)."""
    if verification.status == "run":
        verdicts = [r.verdict for r in verification.rows if r.verdict]
        checked = "agrees" if all(v == "agrees" for v in verdicts) else "disagrees"
    else:
        checked = "not run"
    return [Quantity("range", f"{q.range_N:.3f}", "N"),
            Quantity("amplification", f"{q.amplification:.3f}", ""),
            Quantity("sensitivity", f"{ds.sensitivity_mV_per_N:.1f}", "mV/N"),
            Quantity("resolution", f"{ds.resolution_N * 1e3:.2f}", "mN RMS"),
            Quantity("hysteresis H (predicted)", f"{100 * q.hysteresis:.2f}", "% FS"),
            Quantity("FE check", checked, "")]


def render_figure(design: Design, model, result, parts, window_px=RENDER_WINDOW_PX) -> EmbeddedFigure:
    """The deformed body (``dacm render``'s picture) as an embedded PNG."""
    from sensor.mechanics.render import deformed_body, render_png

    body = deformed_body(design, model, result, parts)
    title = (f"{design.name}: output travel {result.output_travel_mm:.2f} mm "
             f"at input force {result.input_force_N:.2f} N")
    subtitle = (f"displacement scale × {body.scale:g}   (A = {result.amplification:.2f}, "
                f"SE = {result.strain_energy_mJ:.3g} mJ; grey: undeformed)")
    with tempfile.TemporaryDirectory(prefix="dacm-report-") as tmp:
        path = Path(tmp) / "render.png"
        render_png(body, path, title, subtitle, window_px)
        src = image_data_uri(path.read_bytes(), "png")
    return EmbeddedFigure(
        src, f"3D picture of {design.name}, deformed",
        f"The body at the solved state (coloured by strain energy density, log scale; rigid "
        f"parts blue-grey) over the undeformed body (grey). Displacements are magnified "
        f"× {body.scale:g}.")


def verification_from_dict(data: dict) -> Verification:
    """The report's view of a ``verification_to_dict`` result: beam against FE for A, k_out
    and SE (verdicts against :data:`VERIFY_LIMITS_PCT`) and the hinge neck stresses."""
    labels = (("amplification", "amplification A", ""), ("k_out_N_per_mm", "output stiffness k_out", "N/mm"),
              ("strain_energy_mJ", "strain energy SE", "mJ"))
    rows = []
    for key, label, unit in labels:
        err = data["errors_pct"][key]
        limit = VERIFY_LIMITS_PCT.get(key)
        verdict = "" if limit is None else ("agrees" if abs(err) <= limit else "disagrees")
        rows.append(ComparisonRow(label, unit, f"{data['fe'][key]:.4f}", f"{data['beam'][key]:.4f}",
                                  f"{err:+.2f}", f"{data['convergence'][key]['error_pct']:.3f}",
                                  "" if limit is None else f"|error| ≤ {limit:g} %", verdict))
    fe_s, beam_s = data["fe"]["hinge_stress_MPa"], data["beam"]["hinge_stress_MPa"]
    hinge_rows = tuple(HingeStressRow(str(h), f"{fe_s[h]:.2f}", f"{beam_s[h]:.2f}",
                                      f"{data['errors_pct']['hinge_stress_MPa'][h]:+.1f}",
                                      f"{data['beam']['hinge_peak_stress_MPa'][h]:.1f}") for h in fe_s)
    mesh, opts = data["mesh"], data["options"]
    method = (f"{'plane strain' if opts['plane_strain'] else 'plane stress'}, "
              f"{'geometrically nonlinear' if opts['nonlinear'] else 'linear'}; quadratic "
              f"triangles, {mesh['elements']} elements, {mesh['elements_across_hinge']:g} across "
              f"each hinge (finest of three meshes; FE values Richardson-extrapolated, with "
              f"the estimated discretisation error); at {opts['output_travel_mm']:g} mm output "
              f"travel" + ("" if opts["nonlinear"] else ", the beam model in its linear limit "
                           "scaled to it (the solve of section 2 is nonlinear)"))
    return Verification("run", rows=tuple(rows), hinge_rows=hinge_rows, method=method, data=data)


def stress_field(design: Design, v) -> EmbeddedFigure:
    """The FE stress field of a verification (``dacm verify``'s figure), the colour scale
    to 1.2 x the allowable, which the colour bar marks."""
    from sensor.mechanics.plots import stress_field_figure

    title = (f"{design.name}: continuum FE at {v.fe.output_travel_mm:g} mm output; "
             "labels: hinge: stress one t inside the neck (MPa)")
    return svg_figure(
        stress_field_figure(v.fe, design, title, v.fe_summary["hinge_stress_MPa"]), f"{design.name}-stress-field.svg",
        f"FE stress field of {design.name}",
        f"Von Mises stress of the continuum FE on the deformed mesh, with a zoom on the most "
        f"stressed hinge; the colour scale runs to 1.2 × the allowable "
        f"({design.material.allowable_stress_MPa:g} MPa, the red mark on the colour bar).")


def continuum_verification(design: Design, target_output_mm: float, run: bool = True) -> Verification:
    """Run the continuum verification if the tool has it (``sensor.mechanics.continuum``
    with ``verify_design`` and ``verification_to_dict``), else say why it was not run."""
    if not run:
        return Verification("not run", "not requested (--no-verify)")
    try:
        from sensor.mechanics.continuum import verification_to_dict, verify_design
    except ModuleNotFoundError as exc:
        if exc.name != _CONTINUUM:
            raise
        return Verification("not run", f"this version of dacm has no continuum model ({_CONTINUUM})")
    except ImportError:
        return Verification("not run", f"{_CONTINUUM} has no verify_design / verification_to_dict")
    v = verify_design(design, target_output_mm=target_output_mm)
    return dataclasses.replace(verification_from_dict(verification_to_dict(v)), figure=stress_field(design, v))


# --- MRI artefact (sensor.artefact): section 8 ---------------------------------------------

@dataclass(frozen=True)
class ArtefactSection:
    """The predicted MRI artefact as the report shows it: the scan, the rows, two figures
    and :meth:`sensor.artefact.prediction.Artefact.summary` (``data``)."""

    scan: str
    rows: tuple[Quantity, ...]
    field: EmbeddedFigure
    image: EmbeddedFigure
    data: dict


def artefact_section(design: Design) -> ArtefactSection:
    """``dacm artefact``'s prediction at its defaults (water phantom, 3 T along the sheet's
    normal, gradient echo TE 10 ms, 130 Hz/px, 1 mm voxels, 0.5 mm field voxels)."""
    from sensor.artefact.plots import field_figure, image_figure
    from sensor.artefact.prediction import Protocol, predict

    a = predict(design, Protocol())
    s, p = a.summary(), a.protocol
    ge = s["gradient_echo"]
    rows = [Quantity("susceptibility body / fiber / mirror",
                     " / ".join(f"{v:.2f}" for v in s["chi_ppm"].values()), "ppm",
                     f"{s['material']}, PMMA fiber, silicon mirror; {s['medium']} {s['chi_medium_ppm']:g} ppm")]
    rows += [Quantity(f"field offset {r['distance_mm']:g} mm from the surface", f"{r['ppm']:.3g}",
                      "ppm", f"{r['hz']:.3g} Hz; spin-echo shift {r['spin_echo_shift_px']:.2f} px")
             for r in s["surface_offsets"]]
    rows.append(Quantity("gradient-echo artefact (loss > 30 %)", f"{ge['extent_mm']:.1f}", "mm",
                         f"from the surface; {ge['volume_mm3']:.0f} mm³ outside the sensor"
                         + (" (reaches the box: a lower bound)" if ge["reaches_fov_edge"] else "")))
    scan = (f"{p.b0_T:g} T along the sheet's normal, gradient echo TE {p.te_ms:g} ms, "
            f"{p.bandwidth_hz_per_px:g} Hz/px, {p.voxel_mm:g} mm voxels, in a water phantom")
    field = EmbeddedFigure(
        figure_data_uri(field_figure(a), "png"), f"field offset around {design.name}",
        "The B0 offset of the body, fiber and mirror (dipole kernel by FFT, Lorentz-corrected) "
        "on three slices; black: the sensor's outline.")
    image = EmbeddedFigure(
        figure_data_uri(image_figure(a), "png"), f"simulated gradient-echo image of {design.name}",
        "Simulated gradient-echo magnitude (1: the phantom without the sensor); red: the "
        "region losing more than 30 % of its signal (ASTM F2119), blue: the sensor's outline.")
    return ArtefactSection(scan, tuple(rows), field, image, s)


# --- the report --------------------------------------------------------------------------

def _solve_summary(design: Design, r, q, a_kin: float) -> dict:
    return {"design": design.name, **dataclasses.asdict(q), "A_kin": a_kin,
            "input_force_N": r.input_force_N, "input_travel_mm": r.input_travel_mm,
            "output_travel_mm": r.output_travel_mm, "increments": r.increments,
            "residual": r.residual, "converged": r.converged,
            "hinge_rotation_deg": {str(k): v for k, v in r.hinge_rotation_deg.items()}}


def write_design_report(design: Design, out_dir: str | Path, *, target_output_mm: float = 1.0,
                        verify: bool = True, command: str = "", force: bool = False) -> DesignReport:
    """Compute every section, then write the export files, ``<name>.toml`` and
    ``<name>-report.html`` into ``out_dir`` (created if missing).

    An existing output file is replaced only with ``force`` (otherwise ``FileExistsError``
    naming it, before anything is computed or written). ``command`` is the command line
    stated among the inputs.
    """
    from geometry.checks import assert_feasible, check_design
    from geometry.drawing import profile_figure
    from geometry.export import export_design
    from geometry.layout import kinematic_amplification, make_layout, make_parts
    from geometry.params import save_design
    from geometry.topology import build_beam_model
    from sensor.errors import SensorInputError
    from sensor.mechanics.hysteresis import DEFAULT_LAW
    from sensor.mechanics.plots import hinge_stress_figure
    from sensor.mechanics.qualifiers import qualify
    from sensor.mechanics.solver import solve
    from sensor.mechanics.stress import hinge_stresses, stress_check
    from sensor.readout.datasheet import cross_axis, datasheet
    from sensor.readout.plots import calibration_figure, intensity_figure
    from sensor.readout.sensor_model import build_sensor

    if not (isinstance(target_output_mm, (int, float)) and math.isfinite(target_output_mm)
            and target_output_mm > 0):
        raise SensorInputError(f"target_output_mm = {target_output_mm!r}: must be a positive number (mm)")
    out = Path(out_dir)
    if not force:
        for path in output_paths(design, out):
            if path.exists():
                raise FileExistsError(f"{path} exists; not replaced without force")
    assert_feasible(design)

    model = build_beam_model(design)
    r = solve(model, target_output_mm=target_output_mm)
    q = qualify(r, DEFAULT_LAW)
    a_kin = kinematic_amplification(design.phi1_deg, design.phi2_deg)
    sensor = build_sensor(design, target_output_mm=target_output_mm)
    ds = datasheet(sensor, material=design.material.name)
    cross = cross_axis(design, sensor.input_travel_mm)
    stresses = hinge_stresses(model, r)
    stress = stress_check(design, model, r)
    allowable = design.material.allowable_stress_MPa
    figures = {
        "profile": svg_figure(
            profile_figure(design), f"{design.name}-profile.svg", f"profile of {design.name}",
            "The profile as cut (cf. thesis Figure 48): hinge numbers in red, the input force "
            "on the top plate, the mirror on the output platform facing the fiber."),
        "stress": svg_figure(
            hinge_stress_figure(stresses, allowable, f"{design.name}: hinge peak stress at "
                                f"{target_output_mm:g} mm output (full scale)"),
            f"{design.name}-hinge-stress.svg", f"hinge peak stresses of {design.name}",
            f"Each hinge's peak stress at full scale (beam model, root stress concentration "
            f"included) against the allowable {allowable:g} MPa of {design.material.name} (red "
            "line); bar colours on the stress field's scale."),
        "calibration": svg_figure(
            calibration_figure(sensor, ds), f"{design.name}-calibration.svg", f"calibration cycle of {design.name}",
            "A simulated loading–unloading calibration cycle, noise-free (cf. thesis Figures 43 "
            "and 45), and the error of the reading against the applied force."),
        "intensity": svg_figure(
            intensity_figure(sensor, ds, INTENSITY_TOLERANCE_PCT), f"{design.name}-intensity.svg",
            f"intensity against gap for {design.name}",
            "Output voltage against the mirror–fiber gap (cf. thesis Figure 62), with the gap "
            "interval the sensor uses (red) and the widest interval within "
            f"{INTENSITY_TOLERANCE_PCT:g} % FS of a line (green)."),
        "render": render_figure(design, model, r, make_parts(make_layout(design))),
    }
    verification = continuum_verification(design, target_output_mm, verify)
    artefact = artefact_section(design)

    # everything is computed: now write, the page last
    written = export_design(design, out)
    toml_path = out / f"{design.name}.toml"
    save_design(design, toml_path)
    files = tuple(file_record(p, out) for p in [*written, toml_path])
    path = report_path(design, out)
    versions = software_versions()
    generated = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    html = render_template(
        "design_report.html.j2", design=design, generated=generated, command=command,
        target_output_mm=target_output_mm, design_rows=design_rows(design),
        key_rows=key_rows(q, ds, verification),
        solve_rows=solve_rows(r, q, a_kin, DEFAULT_LAW),
        hinge_rotations=sorted(r.hinge_rotation_deg.items()),
        rule_rows=rule_rows(check_design(design)), stress=stress,
        peak_stress_rows=peak_stress_rows(stresses, allowable),
        hysteresis_definition=HYSTERESIS_DEFINITION,
        datasheet_rows=datasheet_rows(ds, cross), figures=figures, verification=verification,
        files=files, toml_text=toml_path.read_text(), versions=versions,
        verify_limits=VERIFY_LIMITS_PCT, artefact=artefact,
        reproduce=f"dacm report --config {toml_path.name} --target-output {target_output_mm:g}")
    write_html(html, path, force=True)
    summary = {
        "design": design.name, "report": str(path),
        "solve": _solve_summary(design, r, q, a_kin),
        "feasibility": [{**dataclasses.asdict(rule), "margin": rule.margin if math.isfinite(rule.margin) else None}
                        for rule in check_design(design).results],
        "hinge_peak_stress_MPa": {str(h): s.peak_MPa for h, s in sorted(stresses.items())},
        "allowable_stress_MPa": allowable,
        "datasheet": dataclasses.asdict(ds), "cross_axis": dataclasses.asdict(cross),
        "verification": ({"status": "run", **verification.data} if verification.data
                         else {"status": "not run", "reason": verification.reason}),
        "artefact": artefact.data,
        "files": [dataclasses.asdict(f) for f in files],
        "software": versions, "generated": generated,
    }
    return DesignReport(path, files, summary)
