"""Check the whole default sweep against the reference: python -m tests.regression.check_sweep

Runs `dacm sweep` (this checkout's code, on the reference's grid, make_reference.REFERENCE_SWEEP,
both hinge sets, into a temporary folder) and prints one JSON object: the largest relative
deviation from the reference over every qualifier of both bodies (tolerance 1e-6), whether
the feasibility mask and the kinds of failure reason are identical, and the worst variable.
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

from sensor.design_space.dataset import load_dataset
from tests.regression.make_reference import REFERENCE_SWEEP, sweep_values
from tests.regression.reference import RTOL, deviations, load

ROOT = Path(__file__).resolve().parents[2]
DACM = "import sys; from sensor.cli import main; sys.exit(main())"


def _grid(g) -> str:
    return f"{g.start}:{g.stop}:{g.n}"


def main():
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, "-c", DACM, "sweep", "--out", tmp, "--quiet", "--no-plots",
                        "--phi1", _grid(REFERENCE_SWEEP.phi1), "--phi2", _grid(REFERENCE_SWEEP.phi2)],
                       cwd=ROOT, check=True, capture_output=True)
        ds = load_dataset(Path(tmp) / "sweep.nc")
    dev = deviations(sweep_values(ds), load())
    worst = max(dev, key=dev.get)
    print(json.dumps({"max_rel_deviation": dev[worst], "worst": worst, "tolerance": RTOL,
                      "feasible_identical": dev["sweep/feasible"] == 0.0,
                      "reason_kinds_identical": dev["sweep/reason_kind"] == 0.0,
                      "ok": dev[worst] <= RTOL}))


if __name__ == "__main__":
    main()
