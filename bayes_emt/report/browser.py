"""Headless Chromium: a screenshot of a rendered report, or its DOM after rendering.

Debian's ``chromium`` (``apt-get install chromium``) driven on its command line; Playwright's own
browser download is not needed. Every call uses a fresh profile folder, no network services and
a time limit, so it leaves nothing behind and cannot hang a test; Chromium is killed by the kernel
when the process that started it dies (Linux), and by that process on SIGINT or SIGTERM.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from .._procs import parent_death_preexec

__all__ = ["find_chromium", "screenshot", "dump_dom", "BrowserError"]

_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


class BrowserError(RuntimeError):
    """Chromium is missing or failed (the message says which, with its last stderr line)."""


def find_chromium() -> str | None:
    """Path of a Chromium binary: ``$BAYES_EMT_CHROMIUM``, else the first of chromium,
    chromium-browser, google-chrome on ``PATH``; ``None`` when there is none."""
    env = os.environ.get("BAYES_EMT_CHROMIUM")
    if env:
        return env if Path(env).is_file() else None
    for name in _NAMES:
        path = shutil.which(name)
        if path:
            return path
    return None


def _run(url_or_path: str | Path, extra: list[str], timeout: float) -> subprocess.CompletedProcess:
    exe = find_chromium()
    if exe is None:
        raise BrowserError("no Chromium found (install Debian's chromium, or set BAYES_EMT_CHROMIUM)")
    target = Path(url_or_path)
    url = target.resolve().as_uri() if target.exists() else str(url_or_path)
    with tempfile.TemporaryDirectory(prefix="bayes_emt_chromium_") as profile:
        cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
               f"--user-data-dir={profile}", "--disable-background-networking", "--disable-component-update",
               "--no-first-run", "--disable-extensions", "--disable-sync", *extra, url]
        try:
            # the kernel ends Chromium if this process dies (its own children follow it); an
            # exception here (SIGINT, SIGTERM, the time limit) kills it before re-raising
            res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, check=False,
                                 preexec_fn=parent_death_preexec())
        except subprocess.TimeoutExpired:
            raise BrowserError(f"{exe}: no answer within {timeout:g} s") from None
    if res.returncode != 0:
        last = (res.stderr.strip().splitlines() or ["no output"])[-1]
        raise BrowserError(f"{exe} exited with status {res.returncode}: {last}")
    return res


def screenshot(html: str | Path, png: str | Path, *, width: int = 1200, height: int = 3000,
               timeout: float = 120.0) -> Path:
    """Render ``html`` (a file) in headless Chromium at ``width`` × ``height`` CSS pixels and write
    the screenshot to ``png``."""
    png = Path(png).resolve()
    _run(html, [f"--screenshot={png}", f"--window-size={width},{height}"], timeout)
    if not png.is_file():
        raise BrowserError(f"Chromium wrote no screenshot to {png}")
    return png


def dump_dom(html: str | Path, *, timeout: float = 120.0) -> str:
    """The document's DOM after Chromium rendered it (``--dump-dom``) as HTML text."""
    return _run(html, ["--dump-dom"], timeout).stdout
