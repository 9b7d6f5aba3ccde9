"""Headless Chromium from the system's packages (Debian's ``chromium``), driven by Playwright.

Playwright's own browser download (``playwright install``) is never used: the browser is the
one at :data:`CHROMIUM`, started with :data:`ARGS` (no sandbox, no GPU, no network of its own:
no QUIC, background networking, component updates or sync), so a page that opens here needs
nothing but its file.
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

CHROMIUM = os.environ.get("GEARBENCH_CHROMIUM", "/usr/bin/chromium")
"""The browser: Debian's ``apt-get install chromium`` (``GEARBENCH_CHROMIUM`` overrides)."""
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync"]
VIEWPORT = {"width": 1280, "height": 800}
"""The first screen, CSS pixels."""


def available() -> str:
    """'' when the browser and Playwright are here, else why not (a sentence)."""
    if not Path(CHROMIUM).exists():
        return f"no Chromium at {CHROMIUM} (apt-get install chromium)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "Playwright is not installed (pip install playwright, or the test extra)"
    return ""


@contextmanager
def browser():
    """A headless Chromium (Playwright's ``Browser``), closed on exit."""
    from playwright.sync_api import sync_playwright
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS, headless=True)
        try:
            yield b
        finally:
            b.close()
