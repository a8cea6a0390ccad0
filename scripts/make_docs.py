"""Regenerate every image of docs/ (the README's figures) from the dacm commands that make
them: ``make docs`` (or ``python scripts/make_docs.py [--dacm PATH]``).

Each image is the file a command writes, copied under the README's name; the one addition is
hysteresis-vs-range.png, which the sweep draws again with the ``dacm design --range 5`` body
marked (the sweep alone does not know it). Images in docs/ that no command makes here are
reported (no page should use them). Takes a few minutes (the loop studies are most of it).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
MRI_PAIR = [str(ROOT / "tests/data/mri/siemens_aera_pair" / f"tra_250_2meas_{k}.IMA") for k in (1, 2)]
#: The README's shaded phantom pair (section `dacm snr`), made with the same lines.
SHADED = """import numpy as np; rng = np.random.default_rng(1)
r, c = np.indices((256, 256)) - np.array([121.3, 133.6])[:, None, None]; rho = np.hypot(r, c) / 95
t = 1000 * (0.25 + 0.75 * rho**2) * (rho <= 1) * (r > -85)
[np.save(f'shaded_{n}.npy', np.hypot(t + rng.normal(0, 20, t.shape), rng.normal(0, 20, t.shape))) for n in 'ab']"""

#: (command arguments after ``dacm``, {file the command writes: image in docs/}); ``{out}``
#: is the command's own folder.
JOBS = [
    (["sweep", "--out", "{out}"], {"figure49.png": "figure49.png"}),
    (["draw", "--preset", "sample-a", "--out", "{out}"], {"sample-a-profile.png": "sample-a.png"}),
    (["render", "--preset", "sample-b", "--out", "{out}"], {"sample-b-render.png": "render-sample-b.png"}),
    (["sensor", "--preset", "sample-a-as-cut", "--out", "{out}"],
     {"sample-a-as-cut-calibration.png": "sensor-calibration.png"}),
    (["line", "--length", "7.25", "--bore", "0.004", "--volume", "4.5e-5", "--pressure", "5e5", "--out", "{out}"],
     {"line-frequency-response.png": "line-frequency-response.png", "line-step.png": "line-step.png"}),
    (["loop", "--out", "{out}"], {"loop.png": "loop-run.png"}),
    (["loop", "--study", "observer", "--out", "{out}"],
     {"loop-observer-phase.png": "loop-observer-phase.png", "loop-observer-smc.png": "loop-observer-smc.png"}),
    (["loop", "--study", "controllers", "--out", "{out}"],
     {"loop-controllers-mse.png": "loop-controllers-mse.png",
      "loop-controllers-virtual-input.png": "loop-controllers-virtual-input.png"}),
    (["loop", "--study", "sensor", "--out", "{out}"], {"loop-sensor.png": "loop-sensor.png"}),
    (["snr", "{out}/shaded_a.npy", "{out}/shaded_b.npy", "--figure", "{out}/mri-shaded.png"],
     {"mri-shaded.png": "mri-shaded.png"}),
    (["snr", *MRI_PAIR, "--figure", "{out}/mri-pair.png"], {"mri-pair.png": "mri-pair.png"}),
]


def dacm(exe: list[str], args: list[str], out: Path, json_out: bool = False) -> dict | None:
    """Run one dacm command with ``{out}`` filled in; its JSON when asked."""
    words = [a.replace("{out}", str(out)) for a in args] + ["--quiet"] + (["--json"] if json_out else [])
    print("+ dacm", " ".join(words), flush=True)
    run = subprocess.run([*exe, *words], check=True, text=True,
                         stdout=subprocess.PIPE if json_out else subprocess.DEVNULL)
    return json.loads(run.stdout) if json_out else None


def hysteresis_vs_range(exe: list[str], work: Path) -> Path:
    """The sweep's hysteresis-vs-range figure with the 5 N ``dacm design`` body marked."""
    from sensor.design_space.dataset import load_dataset
    from sensor.design_space.equal_range import pareto_front
    from sensor.design_space.plots import plot_hysteresis_vs_range

    try:
        design = dacm(exe, ["design", "--range", "5", "--out", "{out}"], work / "design", json_out=True)
        marked = {"dacm design --range 5": {"range_N": design["range_N"], "hysteresis": design["hysteresis_fraction"],
                                            "resolution_N": design["resolution_N"]}}
    except subprocess.CalledProcessError:
        print("dacm design --range 5 failed (see above): hysteresis-vs-range.png drawn without it", flush=True)
        marked = None
    ds = load_dataset(work / "sweep" / "sweep.nc")
    fronts = {str(h): pareto_front(ds, str(h)) for h in ds["hinges"].values}
    plot_hysteresis_vs_range(ds, fronts, work / "figures", marked)
    return work / "figures" / "hysteresis-vs-range.png"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dacm", default=shutil.which("dacm") or "dacm", help="the dacm command to run")
    p.add_argument("--only", nargs="+", metavar="IMAGE", help="remake only these images of docs/")
    args = p.parse_args()
    wanted = set(args.only or [im for _, files in JOBS for im in files.values()] + ["hysteresis-vs-range.png"])
    exe = [args.dacm]
    made = {}
    with tempfile.TemporaryDirectory(prefix="dacm-docs-") as tmp:
        work = Path(tmp)
        (work / "figures").mkdir()
        subprocess.run([sys.executable, "-c", SHADED], check=True, cwd=work / "figures")
        for i, (words, files) in enumerate(JOBS):
            needed = wanted & set(files.values()) or (words[0] == "sweep" and "hysteresis-vs-range.png" in wanted)
            if not needed:
                continue
            out = work / ("sweep" if words[0] == "sweep" else "figures" if words[0] == "snr" else f"job{i}")
            dacm(exe, words, out)
            for name, image in files.items():
                made[image] = shutil.copyfile(out / name, DOCS / image)
        if "hysteresis-vs-range.png" in wanted:
            made["hysteresis-vs-range.png"] = shutil.copyfile(hysteresis_vs_range(exe, work),
                                                              DOCS / "hysteresis-vs-range.png")
    for image in sorted(made):
        print("wrote", made[image].relative_to(ROOT))
    unused = sorted(p.name for p in DOCS.glob("*.png") if p.name not in made)
    if unused and not args.only:
        print("not made by any command (remove if no page uses them):", ", ".join(unused))
    return 0


if __name__ == "__main__":
    sys.exit(main())
