"""What ``dacm design`` writes and prints of a designed body: its file set (written into a
folder the caller stages) and the two lines describing a body."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

#: The files of a design, in the order written (``basis.toml`` only when a basis body exists).
FILES = ("design.toml", "design-datasheet.json", "design-tolerance.json", "design-profile.png",
         "design-drawing.svg", "design-drawing.png", "design.dxf", "basis.toml")


def write_design_files(folder: Path, design, basis_design, datasheet: dict, tolerance: dict,
                       kerf_mm: float) -> list[str]:
    """Write the design's files into ``folder``: the design and basis TOML, the datasheet and
    tolerance report (JSON), the profile, the dimensioned drawing (SVG and PNG) and the DXF
    with the jet's kerf compensation (``kerf_mm`` 0: the drawn profile). Returns the names."""
    from geometry.atomic import atomic_path, save_figure
    from geometry.drawing import dimensioned_figure, profile_figure
    from geometry.export import export_design
    from geometry.params import save_design

    save_design(design, folder / "design.toml")
    with atomic_path(folder / "design-datasheet.json") as tmp:
        tmp.write_text(json.dumps(datasheet, indent=1))
    with atomic_path(folder / "design-tolerance.json") as tmp:
        tmp.write_text(json.dumps({"design": design.name, "tolerance": tolerance}, indent=1))
    save_figure(profile_figure(design), folder / "design-profile.png", dpi=150)
    fig = dimensioned_figure(design, kerf_mm)
    save_figure(fig, folder / "design-drawing.svg")
    save_figure(fig, folder / "design-drawing.png", dpi=150)
    dxf_dir = folder / "dxf"
    dxf_dir.mkdir()
    (dxf,) = export_design(design, dxf_dir, ["dxf"], kerf_mm=kerf_mm or None)
    shutil.move(dxf, folder / "design.dxf")
    dxf_dir.rmdir()
    if basis_design is not None:
        save_design(basis_design, folder / "basis.toml")
    return [name for name in FILES if name != "basis.toml" or basis_design is not None]


def body_lines(label: str, d: dict) -> list[str]:
    """The lines that describe a body of ``describe``'s dict (angles, hinges, range, H,
    resolution, A, k_out, SE, stress; a warning next to the toggle)."""
    from geometry.params import design_from_dict
    from sensor.mechanics.toggle import StrokeChange

    f = d["design"]
    used = design_from_dict(f).used_thickness_mm
    angles = f"phi1 = {f['phi1_deg']:.2f}" + (f", phi2 = {f['phi2_deg']:.2f}" if "phi2_deg" in f else "")
    warning = StrokeChange.from_dict(d, f.get("phi2_deg")).warning()
    return [f"  {label:<12} {angles} deg, hinges {' '.join(f'{t:.4f}' for t in used)} mm",
            f"               range {d['range_N']:.4f} N, H = {d['hysteresis']:.4f}, resolution "
            f"{1e3 * d['resolution_N']:.3f} mN, A = {d['amplification']:.3f}, k_out {d['k_out_N_per_mm']:.3f} N/mm, "
            f"SE {d['strain_energy_mJ']:.4f} mJ, stress {d['stress_utilisation']:.3f} x allowable"] + (
        [f"               warning: {warning}"] if warning else [])
