"""Open an HTML report in a real headless browser (Debian's ``chromium``) and collect what a
reader meets: the picture of the page, the console messages, and whether each image loaded.

Two runs of ``chromium --headless``, about a second each:

1. the page as written: ``--screenshot`` and the console log (``--enable-logging=stderr``;
   every ``console.*`` message and every blocked or failed load shows as a ``CONSOLE`` line);
2. a copy with a probe script appended that, after the page's ``load`` event (every image
   loaded or failed), writes ``[complete, naturalWidth, naturalHeight, src]`` of each ``<img>``
   into the DOM, read back with ``--dump-dom``. A report's Content-Security-Policy allows no
   script, so the copy's policy gains exactly ``script-src 'sha256-<the probe's hash>'``;
   its image rules are unchanged, so an image the policy blocks still fails to load.

``chromium_or_skip()`` skips a test when chromium is absent, except on CI (``CI`` set),
where the browser test must run and a missing browser fails it.
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
import os
import re
import shutil
import subprocess
from dataclasses import dataclass
from html.parser import HTMLParser
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

#: Headless, offline, no profile state, no sandbox (containers run as root).
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--enable-logging=stderr", "--v=0")

#: A browser run that takes longer than this is a failure, not a wait.
TIMEOUT_S = 30

PROBE = ("addEventListener('load', () => { const p = document.createElement('pre'); "
         "p.id = 'dacm-probe'; p.textContent = JSON.stringify(Array.from(document.images, "
         "i => [i.complete, i.naturalWidth, i.naturalHeight, i.src.slice(0, 40)])); "
         "document.body.append(p); });")

_CONSOLE = re.compile(r":CONSOLE[:(]")


@dataclass(frozen=True)
class BrowserCheck:
    """What the browser showed: the screenshot (H, W, channels) uint8, the console lines,
    and per ``<img>`` (complete, naturalWidth, naturalHeight, start of src)."""

    screenshot: np.ndarray
    console: list[str]
    images: list[list]


def chromium_or_skip() -> str:
    """The chromium executable; skip the test if absent (fail on CI, where it must run)."""
    path = shutil.which("chromium")
    if path:
        return path
    if os.environ.get("CI"):
        pytest.fail("chromium is not installed, and on CI the browser test must run "
                    "(apt-get install chromium)")
    pytest.skip("chromium is not installed (apt-get install chromium); CI installs it and "
                "runs this test")


def _run(chromium: str, args: list[str], profile: Path) -> subprocess.CompletedProcess:
    return subprocess.run([chromium, *FLAGS, f"--user-data-dir={profile}", *args],
                          capture_output=True, text=True, timeout=TIMEOUT_S, check=True)


def _with_probe(page_html: str) -> str:
    digest = base64.b64encode(hashlib.sha256(PROBE.encode()).digest()).decode()
    policy = re.search(r'http-equiv="Content-Security-Policy" content="([^"]*)"', page_html)
    assert policy, "the page has no Content-Security-Policy"
    probed = page_html.replace(policy.group(0), policy.group(0).replace(
        policy.group(1), f"{policy.group(1)}; script-src 'sha256-{digest}'"))
    return probed.replace("</body>", f"<script>{PROBE}</script></body>")


def open_in_browser(page: Path, workdir: Path, window_px: tuple[int, int] = (1200, 900)) -> BrowserCheck:
    """Open ``page`` in headless chromium (scratch files in ``workdir``); see the module."""
    chromium = chromium_or_skip()
    workdir.mkdir(parents=True, exist_ok=True)
    shot = workdir / "screenshot.png"
    run = _run(chromium, [f"--window-size={window_px[0]},{window_px[1]}", f"--screenshot={shot}",
                          page.resolve().as_uri()], workdir / "profile-1")
    console = [line for line in run.stderr.splitlines() if _CONSOLE.search(line)]

    probed = workdir / f"probed-{page.name}"
    probed.write_text(_with_probe(page.read_text(encoding="utf-8")), encoding="utf-8")
    run = _run(chromium, ["--dump-dom", probed.as_uri()], workdir / "profile-2")
    console += [line for line in run.stderr.splitlines() if _CONSOLE.search(line)]
    found = re.search(r'<pre id="dacm-probe">(.*?)</pre>', run.stdout, re.DOTALL)
    assert found, "the probe did not run (no load event, or the script was blocked)"
    return BrowserCheck(iio.imread(shot), console, json.loads(html.unescape(found.group(1))))


def start_tags(text: str) -> list[tuple[str, dict]]:
    """Every start tag of an HTML page with its attributes, in order."""
    class _Tags(HTMLParser):
        def handle_starttag(self, tag, attrs):
            tags.append((tag, dict(attrs)))

    tags: list[tuple[str, dict]] = []
    _Tags().feed(text)
    return tags
