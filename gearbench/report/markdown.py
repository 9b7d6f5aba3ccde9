"""Generated blocks inside hand-written Markdown files.

A results file such as ``results/gain_scan.md`` mixes prose with tables that
commands regenerate.  Each generated part sits between two HTML comments::

    <!-- gearbench:TAG begin -->
    ...generated...
    <!-- gearbench:TAG end -->

and :func:`update_block` replaces only that part (appending it the first time),
atomically, so rerunning a command refreshes its numbers and keeps the prose.
"""
from __future__ import annotations

import re
from pathlib import Path

from .io import write_text_atomic


def markers(tag: str) -> tuple[str, str]:
    return f"<!-- gearbench:{tag} begin -->", f"<!-- gearbench:{tag} end -->"


def update_block(path: str | Path, tag: str, text: str) -> Path:
    """Put ``text`` between the ``tag`` markers of ``path`` (created if missing)."""
    path = Path(path)
    begin, end = markers(tag)
    block = f"{begin}\n{text.strip()}\n{end}"
    old = path.read_text(encoding="utf-8") if path.exists() else ""
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), re.S)
    if pattern.search(old):
        new = pattern.sub(lambda _: block, old, count=1)
    else:
        new = (old.rstrip() + "\n\n" if old.strip() else "") + block + "\n"
    return write_text_atomic(path, new)
