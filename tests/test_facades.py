"""The public facades: every name in ``__all__`` resolves, and the command line starts
without the heavy libraries (CadQuery, pyvista, matplotlib)."""

import importlib
import subprocess
import sys

import pytest


@pytest.mark.parametrize("package", ["geometry", "sensor", "mri"])
def test_every_public_name_resolves(package):
    mod = importlib.import_module(package)
    assert mod.__all__ == sorted(mod.__all__)
    for name in mod.__all__:
        assert getattr(mod, name) is not None, name
    with pytest.raises(AttributeError):
        getattr(mod, "no_such_name")


def test_help_imports_nothing_heavy():
    code = ("import sys; from sensor.cli import build_parser; build_parser(); "
            "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))")
    loaded = set(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                check=True).stdout.split())
    assert not loaded & {"cadquery", "OCP", "pyvista", "vtk", "matplotlib", "xarray", "numba"}
