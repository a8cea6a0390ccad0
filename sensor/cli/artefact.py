"""``dacm artefact``: the MRI artefact of a design's sensor before it is cut (the B0 offset
its body, fiber and mirror make, the spin-echo shift and the gradient-echo signal loss)."""

from __future__ import annotations

import argparse
import json

from sensor.cli.design_args import add_design_arguments, check_flags, design_from_args
from sensor.cli.output import add_output_arguments, claim, make_out_dir, print_json
from sensor.cli.progress import add_quiet_argument, busy

#: Library field -> flag, for the one-line errors.
FLAGS = {"b0_T": "--b0", "te_ms": "--te-ms", "bandwidth_hz_per_px": "--bandwidth-hz-per-px",
         "voxel_mm": "--voxel-mm", "resolution_mm": "--resolution-mm", "margin_mm": "--margin-mm",
         "b0_direction": "--b0-direction"}


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "artefact", help="predict the sensor's MRI artefact: field offset, spin-echo shift, "
                         "gradient-echo signal loss",
        description="Voxelise the design's body, fiber and mirror in a water phantom (or air), "
                    "compute the B0 offset they make (dipole kernel by FFT, Lorentz-corrected) and "
                    "from it the offset 1, 2 and 5 mm from the surface, the spin-echo readout "
                    "shift and the extent of the gradient-echo signal loss above 30 %% (ASTM "
                    "F2119). Writes OUT/<name>-artefact.json (the numbers), -artefact-field.png "
                    "and -artefact-image.png (three slices each) and -artefact.nc (the field "
                    "map in ppm and Hz, the simulated image; NetCDF-4). Linear magnetisation; "
                    "no eddy currents, no chemical shift.")
    add_design_arguments(p)
    p.add_argument("--b0", type=float, default=3.0, metavar="T", help="main field, T (default 3)")
    p.add_argument("--te-ms", type=float, default=10.0, metavar="MS",
                   help="gradient-echo echo time, ms (default 10)")
    p.add_argument("--bandwidth-hz-per-px", type=float, default=130.0, metavar="HZ",
                   help="readout bandwidth per pixel, Hz (default 130)")
    p.add_argument("--voxel-mm", type=float, default=1.0, metavar="MM",
                   help="isotropic image voxel, mm (default 1; a whole multiple of --resolution-mm)")
    p.add_argument("--resolution-mm", type=float, default=0.5, metavar="MM",
                   help="voxel of the field model, mm (default 0.5)")
    p.add_argument("--margin-mm", type=float, default=30.0, metavar="MM",
                   help="medium around the sensor on every side, mm (default 30)")
    p.add_argument("--medium", choices=("water", "air"), default="water",
                   help="what surrounds the sensor (default water: an ASTM F2119 phantom)")
    p.add_argument("--b0-direction", default="z", metavar="DIR",
                   help="B0 in the sensor's frame: x (across), y (force axis), z (through the "
                        "sheet; default) or a vector such as 0,1,1")
    add_output_arguments(p, "the JSON numbers, the two figures and the maps")
    p.add_argument("--json", action="store_true", help="print the numbers as JSON")
    add_quiet_argument(p)
    p.set_defaults(func=run)


def output_names(name: str) -> list[str]:
    return [f"{name}-artefact.json", f"{name}-artefact-field.png", f"{name}-artefact-image.png",
            f"{name}-artefact.nc"]


def run(args: argparse.Namespace) -> int:
    from sensor.artefact.field import b0_unit
    from sensor.artefact.prediction import GRID_RULES, PROTOCOL_RULES, Protocol, block_factor
    from sensor.errors import ArtefactError, UsageError

    design = design_from_args(args)
    check_flags(args, {"b0": PROTOCOL_RULES["b0_T"], "te_ms": PROTOCOL_RULES["te_ms"],
                       "bandwidth_hz_per_px": PROTOCOL_RULES["bandwidth_hz_per_px"],
                       "voxel_mm": PROTOCOL_RULES["voxel_mm"], **GRID_RULES})
    try:
        b0_unit(args.b0_direction)
        block_factor(args.voxel_mm, args.resolution_mm)
        protocol = Protocol(args.b0, args.te_ms, args.bandwidth_hz_per_px, args.voxel_mm)
    except ArtefactError as exc:
        raise UsageError(_flagged(str(exc))) from None
    paths = claim(args, output_names(design.name))
    with busy(f"artefact {design.name}", args.quiet) as step:
        from geometry.atomic import atomic_path, save_figure
        from sensor.artefact.dataset import artefact_dataset, write_dataset
        from sensor.artefact.plots import field_figure, image_figure
        from sensor.artefact.prediction import predict

        step("voxels, field and image")
        a = predict(design, protocol, args.medium, args.b0_direction, args.resolution_mm, args.margin_mm)
        summary = {**a.summary(), "files": [str(p) for p in paths]}
        step("figures")
        figures = (field_figure(a), image_figure(a))
        maps = artefact_dataset(a)  # everything is built before the first file is written
        make_out_dir(args.out)
        with atomic_path(paths[0]) as tmp:
            tmp.write_text(json.dumps(summary, indent=1) + "\n")
        for fig, path in zip(figures, paths[1:3]):
            save_figure(fig, path)
        with atomic_path(paths[3]) as tmp:
            write_dataset(maps, tmp)
    if args.json:
        print_json(summary, paths)
        return 0
    print(describe(summary))
    for p in paths:
        print(f"wrote {p}")
    return 0


def describe(s: dict) -> str:
    """The numbers as a few lines of text."""
    ge = s["gradient_echo"]
    lines = [f"{s['design']} ({s['material']}, chi {s['chi_ppm']['body']:g} ppm) in {s['medium']} "
             f"({s['chi_medium_ppm']:g} ppm), B0 {s['b0_T']:g} T along "
             f"({', '.join(f'{v:.3g}' for v in s['b0_direction'])}); field voxel "
             f"{s['resolution_mm']:g} mm, grid {'x'.join(map(str, s['grid_shape']))} "
             f"(FFT {'x'.join(map(str, s['fft_shape']))})",
             f"  largest offset in the {s['medium']}: {s['max_offset_ppm']:.3g} ppm = "
             f"{s['max_offset_hz']:.3g} Hz"]
    for row in s["surface_offsets"]:
        lines.append(f"  {row['distance_mm']:g} mm from the surface: {row['ppm']:.3g} ppm = "
                     f"{row['hz']:.3g} Hz; spin-echo shift {row['spin_echo_shift_px']:.2f} px at "
                     f"{s['bandwidth_hz_per_px']:g} Hz/px")
    lines.append(f"  gradient echo TE {s['te_ms']:g} ms, voxel {s['voxel_mm']:g} mm: signal loss > "
                 f"{100 * ge['loss_threshold']:.0f} % reaches {ge['extent_mm']:.1f} mm from the surface "
                 f"({ge['volume_mm3']:.0f} mm^3 outside the sensor)"
                 + (" - it reaches the box's edge: a lower bound, enlarge --margin-mm"
                    if ge["reaches_fov_edge"] else ""))
    return "\n".join(lines)


def _flagged(message: str) -> str:
    """A library message with its fields named as the flags that set them."""
    for field, flag in FLAGS.items():
        message = message.replace(f"{field} = ", f"{flag} = ")
    return message
