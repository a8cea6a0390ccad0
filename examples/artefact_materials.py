"""The thesis' material choice in numbers: the same sample-b sensor (PMMA fiber, silicon
mirror) with its body in delrin, ABS and aluminium, in a water phantom and in air, at 3 T
(B0 through the sheet), gradient echo TE 10 ms, 130 Hz/px, 1 mm voxels, 0.5 mm field voxels.

Run from the repository root:  .venv/bin/python examples/artefact_materials.py [figure.png]
One row of it comes from:      dacm artefact --preset sample-b --material abs
"""

import sys
from pathlib import Path

from geometry.atomic import save_figure
from geometry.params import preset
from sensor.artefact.plots import comparison_figure
from sensor.artefact.prediction import Protocol, predict

MATERIALS = ("delrin", "abs", "aluminium")

design, protocol = preset("sample-b"), Protocol(3.0, 10.0, 130.0, 1.0)
water = [predict(design, protocol, "water", body_material=m) for m in MATERIALS]
air = {m: predict(design, protocol, "air", body_material=m).summary() for m in MATERIALS}

print("| body | chi (ppm) | offset at 1 / 2 / 5 mm (ppm) | spin-echo shift at 1 mm (px) "
      "| GRE artefact in water (mm; mm^3) | in air (mm) |")
print("|---|---|---|---|---|---|")
for a in water:
    s = a.summary()
    rows = s["surface_offsets"]
    ge, ge_air = s["gradient_echo"], air[a.body_material]["gradient_echo"]
    print(f"| {a.body_material} | {s['chi_ppm']['body']:+.2f} | "
          + " / ".join(f"{r['ppm']:.3g}" for r in rows)
          + f" | {rows[0]['spin_echo_shift_px']:.2f} | {ge['extent_mm']:.1f}; {ge['volume_mm3']:.0f} "
          f"| {ge_air['extent_mm']:.1f}{' (box edge)' if ge_air['reaches_fov_edge'] else ''} |")

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("artefact-materials.png")
save_figure(comparison_figure(water), out, dpi=100)
print(f"figure: {out}")
