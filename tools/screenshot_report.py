"""The first screen of an HTML report as a PNG, in headless Chromium (``tools/browser.py``).

    python tools/screenshot_report.py [REPORT.html] [OUT.png] [--full]

Defaults: the tutorial's diagnosis report, which ``make run`` writes
(``results/diagnose_bench_rig_bench_rig_hidden/report.html``), to
``docs/assets/report-diagnose.png``, the docs' picture of it: 1280 x 800 CSS pixels
(``--full``: the whole page).
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tools.browser import VIEWPORT, available, browser  # noqa: E402

REPORT = ROOT / "results" / "diagnose_bench_rig_bench_rig_hidden" / "report.html"
OUT = ROOT / "docs" / "assets" / "report-diagnose.png"


def screenshot(report: Path, out: Path, full_page: bool = False) -> Path:
    """Open ``report`` from its file and save its first screen (or the whole page) to ``out``."""
    out.parent.mkdir(parents=True, exist_ok=True)
    with browser() as b:
        page = b.new_page(viewport=VIEWPORT)
        page.goto(report.resolve().as_uri(), wait_until="load")
        page.screenshot(path=str(out), full_page=full_page)
    return out


def main(argv: list[str]) -> int:
    full = "--full" in argv
    argv = [a for a in argv if a != "--full"]
    why = available()
    if why:
        print(f"cannot take the screenshot: {why}", file=sys.stderr)
        return 2
    report = Path(argv[0]) if argv else REPORT
    out = Path(argv[1]) if len(argv) > 1 else OUT
    if not report.is_file():
        print(f"no report at {report}: make it first (make run, or gearbench diagnose "
              "experiments/plants/bench_rig.yaml experiments/data/bench_rig_hidden.csv)", file=sys.stderr)
        return 2
    print(f"wrote {screenshot(report, out, full_page=full)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
