"""The JSON contract of every ``dacm`` command (README "JSON contract"): one name per
quantity with its unit in the name, integers as integers, NaN as null, and the files written
as ``{path, bytes, sha256}``."""

from __future__ import annotations

from pathlib import Path

from sensor.output_sets import file_record

#: Former JSON key -> (key of the contract, factor on the value): one name per quantity, its
#: unit in the name. The predicted hysteresis of the strain-energy law and the eq 87
#: hysteresis of a loop are fractions of full scale (``_fraction``), the sensor output's eq 87
#: hysteresis is ``output_hysteresis_fraction``; times are ``_s``.
RENAMED_KEYS = {
    "hysteresis": ("hysteresis_fraction", 1.0),
    "hysteresis_predicted": ("hysteresis_fraction", 1.0),
    "hysteresis_mechanical_pct": ("hysteresis_fraction", 0.01),
    "hysteresis_pct": ("output_hysteresis_fraction", 0.01),
    "seconds": ("wall_s", 1.0),
}


def file_records(paths) -> list[dict]:
    """The contract's ``files``: ``{"path", "bytes", "sha256"}`` of each written file, in
    the order written (``path`` as the command named it, under ``--out``)."""
    return [{"path": str(p), **{k: v for k, v in file_record(Path(p)).items() if k != "name"}} for p in paths]


def contract_json(value):
    """A command's result in the JSON contract: keys of :data:`RENAMED_KEYS` renamed (values
    scaled), numpy scalars as Python numbers (integers stay integers), NaN and inf as null."""
    import math

    import numpy as np

    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            new, factor = RENAMED_KEYS.get(k, (k, 1.0))
            v = contract_json(v)
            out[new] = v * factor if factor != 1.0 and isinstance(v, float) else v
        return out
    if isinstance(value, (list, tuple)):
        return [contract_json(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    return value


def print_json(result: dict, files=None) -> None:
    """Print a command's ``--json`` answer on stdout: ``result`` in the contract
    (:func:`contract_json`) with ``files`` (:func:`file_records`) when the command writes
    files (``files`` given, possibly empty)."""
    import json

    out = contract_json(result)
    if files is not None:
        out["files"] = file_records(files)
    print(json.dumps(out, indent=1))
