"""The susceptibility table and the materials' values."""

import math

import pytest

from geometry.params import MATERIALS, Material, design_from_dict, design_to_dict, preset
from sensor.artefact.susceptibility import (
    MAX_ABS_CHI_PPM,
    SUSCEPTIBILITY_PPM,
    body_chi_ppm,
    check_chi,
    chi_ppm,
    layered_chi_ppm,
)
from sensor.errors import ArtefactError


def test_published_values():
    """Schenck 1996 Table 1 (water, air, aluminium); the polymers within 1 ppm of water."""
    assert SUSCEPTIBILITY_PPM["water"] == -9.05 and SUSCEPTIBILITY_PPM["air"] == 0.36
    assert SUSCEPTIBILITY_PPM["aluminium"] == 20.7
    assert SUSCEPTIBILITY_PPM["silicon"] == pytest.approx(-4.06, abs=0.01)
    for name in ("delrin", "abs"):
        assert abs(MATERIALS[name].chi_ppm - SUSCEPTIBILITY_PPM["water"]) < 1.0


def test_lookup_and_rules():
    assert chi_ppm("delrin") == MATERIALS["delrin"].chi_ppm and chi_ppm("aluminium") == 20.7
    with pytest.raises(ArtefactError, match="'steel'.*no susceptibility"):
        chi_ppm("steel")
    with pytest.raises(ArtefactError, match="chi_ppm is not given"):
        body_chi_ppm(Material("x", 1000.0, 0.3))
    for bad in (math.nan, 2 * MAX_ABS_CHI_PPM, "1"):
        with pytest.raises(ArtefactError, match="linear magnetisation"):
            check_chi("chi", bad)


def test_layers_keep_the_moment():
    assert layered_chi_ppm((("water", 1.0), ("air", 1.0))) == pytest.approx((-9.05 + 0.36) / 2)


def test_chi_round_trips_through_the_design_file():
    d = preset("sample-b")
    assert design_from_dict(design_to_dict(d)).material.chi_ppm == d.material.chi_ppm
    custom = d.replace(material=Material("pom", 2500.0, 0.35))
    assert "chi_ppm" not in design_to_dict(custom)["material"]
    assert design_from_dict(design_to_dict(custom)).material.chi_ppm is None
