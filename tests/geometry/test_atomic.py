"""geometry/atomic.py: a file is under its name only when complete. Write errors are one
OSError naming the file and the errno; a writer that reports success on a cut file (as
OpenCASCADE's STEP writer does under a file-size limit) is caught by the format's end."""

from __future__ import annotations

import errno
import json
from pathlib import Path

import pytest

from geometry import atomic
from geometry.atomic import WriteError, atomic_path, check_complete, write_bytes

#: A complete file of each checked format, and the same file cut short.
COMPLETE = {
    "a.step": b"ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n#1=X();\nENDSEC;\nEND-ISO-10303-21;\n",
    "a.dxf": b"  0\nSECTION\n  0\nENDSEC\n  0\nEOF\n",
    "a.svg": b"<?xml version='1.0'?>\n<svg>\n</svg>\n",
    "a.html": b"<!doctype html><html><body>x</body></html>\n",
    "a.json": json.dumps({"a": [1, 2, 3]}).encode(),
    "a.toml": b"[design]\nphi1_deg = 20.0\n",
    "a.csv": b"x [mm],y [N]\n1,2\n",
    "a.png": b"\x89PNG\r\n\x1a\n" + b"\x00" * 20 + b"\x00\x00\x00\x00IEND\xaeB`\x82",
    "a.stl": b"\x00" * 80 + (2).to_bytes(4, "little") + b"\x01" * 100,
}


@pytest.mark.parametrize("name", sorted(COMPLETE))
def test_a_complete_file_passes_and_any_cut_fails(tmp_path, name):
    path = tmp_path / name
    data = COMPLETE[name]
    path.write_bytes(data)
    check_complete(path)
    for cut in (len(data) - 3, len(data) // 2, 0):
        path.write_bytes(data[:cut])
        with pytest.raises(WriteError, match=f"cannot write {path}"):
            check_complete(path)


def test_a_silent_writer_cut_by_a_full_disk_is_enospc_and_leaves_nothing(tmp_path, monkeypatch):
    """A STEP writer that stops mid-file and reports success, on a disk with no space left
    (simulated): ENOSPC, naming the file; the earlier file stays as it was."""
    target = tmp_path / "a.step"
    target.write_bytes(COMPLETE["a.step"])
    monkeypatch.setattr(atomic.shutil, "disk_usage", lambda p: type("U", (), {"free": 0})())
    with pytest.raises(WriteError) as exc, atomic_path(target) as tmp:
        tmp.write_bytes(COMPLETE["a.step"][:20])
    assert exc.value.errno == errno.ENOSPC
    assert str(exc.value) == (f"[Errno 28] No space left on device (ENOSPC): cannot write {target} "
                              "(the file stopped at 20 bytes, before its end)")
    assert target.read_bytes() == COMPLETE["a.step"]
    assert [p.name for p in tmp_path.iterdir()] == ["a.step"]


def test_a_failed_write_names_the_final_file_not_the_temporary_one(tmp_path, monkeypatch):
    target = tmp_path / "sweep.nc"

    class Full:
        def __init__(self, *args):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def write(self, data):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(atomic, "open", Full, raising=False)
    with pytest.raises(WriteError, match=rf"\(ENOSPC\): cannot write {target}$"):
        write_bytes(target, b"\x89HDF" * 100)
    assert list(tmp_path.iterdir()) == []


def test_nested_writes_name_the_file_that_failed(tmp_path):
    """Several files staged at once (dacm snr's --csv, --figure, --report): the error names
    the file whose write failed, and none of them is left."""
    import contextlib

    with pytest.raises(WriteError, match=f"cannot write {tmp_path / 'a.csv'}"):
        with contextlib.ExitStack() as stack:
            csv = stack.enter_context(atomic_path(tmp_path / "a.csv"))
            stack.enter_context(atomic_path(tmp_path / "b.html"))
            raise OSError(errno.EIO, "Input/output error", str(csv))
    assert list(tmp_path.iterdir()) == []


def test_unchecked_suffixes_pass(tmp_path):
    path = tmp_path / "a.nc"
    path.write_bytes(b"")
    check_complete(Path(path))
