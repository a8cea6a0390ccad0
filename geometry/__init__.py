"""What the body is: design parameters, feasibility, the beam model, CAD and files.

A small lazy facade: ``import geometry`` loads nothing heavy; CadQuery is imported only
when a profile is drawn or exported.

>>> import geometry
>>> d = geometry.preset("sample-b")
>>> geometry.check_design(d).feasible
True
"""

import lazy_loader

__getattr__, __dir__, __all__ = lazy_loader.attach(
    __name__,
    submod_attrs={
        "params": ["Design", "HINGE_SETS", "MATERIALS", "Material", "PRESETS", "load_design", "make_design", "preset", "save_design"],
        "checks": ["assert_feasible", "check_design"],
        "layout": ["kinematic_amplification"],
        "topology": ["BeamModel", "build_beam_model", "load_model"],
        "export": ["export_design"],
        "drawing": ["profile_figure"],
        "errors": ["GeometryError", "InfeasibleDesignError", "ParameterError"],
    },
)
