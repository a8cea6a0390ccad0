"""What the body is: design parameters, feasibility, the beam model, CAD and files.

A small lazy facade: ``import geometry`` loads nothing heavy; CadQuery is imported only
when a profile is drawn or exported.

>>> import geometry
>>> d = geometry.preset("sample-b")
>>> geometry.check_design(d).feasible
True
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "Design": "geometry.params",
    "Material": "geometry.params",
    "MATERIALS": "geometry.params",
    "HINGE_SETS": "geometry.params",
    "PRESETS": "geometry.params",
    "preset": "geometry.params",
    "make_design": "geometry.params",
    "load_design": "geometry.params",
    "save_design": "geometry.params",
    "check_design": "geometry.checks",
    "assert_feasible": "geometry.checks",
    "kinematic_amplification": "geometry.layout",
    "BeamModel": "geometry.topology",
    "build_beam_model": "geometry.topology",
    "load_model": "geometry.topology",
    "export_design": "geometry.export",
    "profile_figure": "geometry.drawing",
    "GeometryError": "geometry.errors",
    "ParameterError": "geometry.errors",
    "InfeasibleDesignError": "geometry.errors",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'geometry' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
