"""``dacm render``: a PNG of the undeformed and the solved, deformed 3D body coloured by
strain energy density (pyvista, off-screen; works without a display)."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from sensor.cli.design_args import (
    add_design_arguments,
    check_flags,
    design_from_args,
    travel_rule,
)
from sensor.validation import Number, require_finite

DEFAULT_OUT_DIR = Path("dacm-out")
DEFAULT_WINDOW = (1600, 1200)
#: Largest picture side (px) accepted by --window-size.
MAX_WINDOW_PX = 8000


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "render", help="PNG of the undeformed and deformed 3D body, coloured by strain energy",
        description="Solve a design to an output travel and draw the extruded body warped by "
                    "the solved displacements (rigid parts move with their nodes, hinges and "
                    "links bend as cubic beams between their end nodes), coloured by strain "
                    "energy density on a log scale, over the undeformed body in grey. The "
                    "displacements are magnified by the stated scale factor. Renders off-screen.")
    add_design_arguments(p)
    p.add_argument("--target-output", type=float, default=1.0, metavar="MM",
                   help="solve until the output port has travelled MM (default 1)")
    p.add_argument("--scale", type=float, metavar="N",
                   help="displacement scale factor (default: automatic, so the largest "
                        "displacement shows as 8%% of the body size, rounded to 1, 2, 5 x 10^k)")
    p.add_argument("--out", type=Path, metavar="FILE.png",
                   help="output picture (default dacm-out/<name>-render.png; the folder is "
                        "created if missing)")
    p.add_argument("--window-size", metavar="WxH", default=f"{DEFAULT_WINDOW[0]}x{DEFAULT_WINDOW[1]}",
                   help="picture size in pixels (default %(default)s)")
    p.set_defaults(func=run)


def parse_window_size(text: str) -> tuple[int, int]:
    """``"WxH"`` -> (W, H) pixels, each in [100, MAX_WINDOW_PX]."""
    from sensor.errors import UsageError

    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or not all(100 <= int(v) <= MAX_WINDOW_PX for v in m.groups()):
        raise UsageError(f"--window-size = {text!r}: must be WxH in pixels, each between "
                             f"100 and {MAX_WINDOW_PX} (e.g. 1600x1200)")
    return int(m.group(1)), int(m.group(2))


def run(args: argparse.Namespace) -> int:
    from geometry.checks import assert_feasible
    from geometry.layout import make_layout, make_parts
    from geometry.topology import build_beam_model
    from sensor.errors import UsageError
    from sensor.mechanics.render import deformed_body, render_png
    from sensor.mechanics.solver import solve

    check_flags(args, {"scale": Number(0.0, 1e6, lo_open=True)})
    if args.out is not None and args.out.suffix.lower() != ".png":
        raise UsageError(f"--out = {str(args.out)!r}: must end in .png")
    window = parse_window_size(args.window_size)
    design = design_from_args(args)
    check_flags(args, {"target_output": travel_rule(design.height_mm)})
    assert_feasible(design)
    out = args.out or DEFAULT_OUT_DIR / f"{design.name}-render.png"

    model = build_beam_model(design)
    result = solve(model, target_output_mm=args.target_output)
    require_finite(f"solve of {design.name}", {k: getattr(result, k) for k in (
        "output_travel_mm", "input_force_N", "amplification", "strain_energy_mJ")})
    body = deformed_body(design, model, result, make_parts(make_layout(design)), args.scale)
    title = (f"{design.name}: output travel {result.output_travel_mm:.2f} mm "
             f"at input force {result.input_force_N:.2f} N")
    subtitle = (f"displacement scale × {body.scale:g}   (A = {result.amplification:.2f}, "
                f"SE = {result.strain_energy_mJ:.3g} mJ; grey: undeformed)")
    out.parent.mkdir(parents=True, exist_ok=True)
    render_png(body, out, title, subtitle, window)
    print(f"wrote {out}")
    return 0
