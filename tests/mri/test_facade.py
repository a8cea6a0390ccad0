"""The ``mri`` facade: lazy (``import mri`` loads no numpy), ``__all__`` agrees with the README's
list, and the README's Python example runs as printed (its numbers are the Aera pair's)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _readme_mri_example() -> str:
    text = (ROOT / "README.md").read_text()
    start = text.index("- `mri`: `load_image`")
    return re.search(r"```python\n(.*?)```", text[start:], re.S).group(1)


def test_import_mri_is_lazy_and_lists_what_the_readme_names():
    code = ("import sys, mri; assert 'numpy' not in sys.modules, 'numpy loaded'; "
            "print(' '.join(sorted(mri.__all__)))")
    names = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                           cwd=ROOT).stdout.split()
    text = (ROOT / "README.md").read_text()
    listed = text[text.index("- `mri`: `load_image`"):text.index("```python", text.index("- `mri`: `load_image`"))]
    assert {"load_image", "load_pair", "measure_pair"} <= set(names)
    missing = [name for name in names if not re.search(rf"\b{name}\b", listed)]
    assert not missing, f"in mri.__all__ but not in the README's mri list: {missing}"
    # every name resolves: tests/test_facades.py


def test_the_readme_example_runs_and_prints_its_comments():
    run = subprocess.run([sys.executable, "-c", _readme_mri_example()], capture_output=True,
                         text=True, cwd=ROOT, check=True)
    lines = run.stdout.splitlines()
    assert lines[0] == "NEMA SNR 220.0 (95 % 213.1-227.0), normalised 2148"
    assert lines[1] == "[]"
