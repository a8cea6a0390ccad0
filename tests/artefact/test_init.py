"""The facade of sensor.artefact: every public name resolves, and importing it loads
nothing heavy."""

import importlib
import subprocess
import sys


def test_every_public_name_resolves():
    mod = importlib.import_module("sensor.artefact")
    assert mod.__all__ == sorted(mod.__all__)
    for name in mod.__all__:
        assert getattr(mod, name) is not None, name


def test_import_is_light():
    code = ("import sys, sensor.artefact; "
            "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))")
    loaded = set(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                check=True).stdout.split())
    assert not loaded & {"trimesh", "cadquery", "OCP", "matplotlib", "scipy"}
