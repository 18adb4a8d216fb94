"""How fast the rule designer redraws after an edit, on a 2000-point path, next to one advice.

    python benchmarks/bench_designer.py [--points 2000] [--edits 12] [--no-browser]

- anchor: one :func:`fuzzyfeed.fuzzy.advisor.advise_details` call on the trident at --points
  samples (median of --edits calls): what any redraw of the path panel must at least cost;
- ``redraw``: in process, the designer's view (no browser) gets --edits edits — a typed
  breakpoint and a rule cell, alternately — and each is timed from the widget's new value until
  every figure's data, the inputs, the validation and the rules diff are updated (median, max);
- ``browser``: ``fuzzyfeed design`` served on 127.0.0.1 and driven in Debian's chromium
  (Playwright): from typing a breakpoint and pressing Enter to the page's surface data having
  changed (the round trip through the websocket; median, max). Skipped without /usr/bin/chromium.

The first edit of a session is reported apart (lazy imports, first paint). The issue asks for a
redraw within 200 ms. The last line: ``redraw_ms=... advise_ms=... redraw_over_advise=...
browser_ms=...``.
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--no-first-run", "--disable-sync"]


def in_process(points: int, edits: int) -> tuple[float, list[float], float]:
    from fuzzyfeed.designer.app import Designer
    from fuzzyfeed.fuzzy.advisor import advise_details

    with tempfile.TemporaryDirectory() as folder:
        from fuzzyfeed.fuzzy.rule_reader import resolve_rules_path

        table = Path(folder) / "bench.toml"
        table.write_text(resolve_rules_path("paper").read_text())
        designer = Designer(table, shape="trident", points=points)
        view = designer.view()
        first = None
        times = []
        for i in range(edits + 1):
            start = time.perf_counter()
            if i % 2:
                view.cells[("VS", "L")].value = "LF" if i % 4 == 1 else "VVHF"
            else:
                view.point_inputs[("curvature", "B", 1)].value = 0.2 + 0.01 * (i % 5 + 1)
            took = time.perf_counter() - start
            if first is None:
                first = took
            else:
                times.append(took)
        anchor = []
        for _ in range(edits):
            start = time.perf_counter()
            advise_details(designer.samples, designer.document.table, 100.0)
            anchor.append(time.perf_counter() - start)
    return statistics.median(anchor), times, first


def in_browser(points: int, edits: int) -> tuple[list[float], float] | None:
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return None
    if not Path(CHROMIUM).is_file():
        return None
    from fuzzyfeed.fuzzy.rule_reader import resolve_rules_path

    folder = tempfile.mkdtemp()
    table = Path(folder) / "bench.toml"
    table.write_text(resolve_rules_path("paper").read_text())
    proc = subprocess.Popen([sys.executable, "-m", "fuzzyfeed", "design", str(table), "--shape", "trident",
                             "--points", str(points), "--no-browser"], stdout=subprocess.PIPE, text=True)
    try:
        url = re.search(r"http://\S+/", proc.stdout.readline()).group(0)
        total = "() => { let s = 0; for (const x of Bokeh.documents[0].get_model_by_name('surface-image')" \
                ".data.image[0]) s += x; return s; }"
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 1500, "height": 1000})
            page.goto(url)
            page.wait_for_function("() => window.Bokeh && Bokeh.documents.length && Bokeh.documents[0]"
                                   ".get_model_by_name('surface-image').data.image", timeout=120000)
            field = page.get_by_label("curvature B b")
            times, first = [], None
            for i in range(edits + 1):
                before = page.evaluate(total)
                field.fill(f"{0.2 + 0.01 * (i % 5 + 1):g}")
                start = time.perf_counter()
                field.press("Enter")
                page.wait_for_function(f"() => ({total})() != {before!r}", polling="raf", timeout=60000)
                took = time.perf_counter() - start
                if first is None:
                    first = took
                else:
                    times.append(took)
            browser.close()
        return times, first
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=2000)
    parser.add_argument("--edits", type=int, default=12)
    parser.add_argument("--no-browser", action="store_true")
    args = parser.parse_args()
    anchor, redraw, first = in_process(args.points, args.edits)
    print(f"anchor: advise_details on trident, {args.points} points: {anchor * 1e3:.1f} ms (median)")
    print(f"redraw in process: median {statistics.median(redraw) * 1e3:.1f} ms, max {max(redraw) * 1e3:.1f} ms "
          f"over {len(redraw)} edits (first edit {first * 1e3:.1f} ms)")
    summary = (f"redraw_ms={statistics.median(redraw) * 1e3:.1f} advise_ms={anchor * 1e3:.1f} "
               f"redraw_over_advise={statistics.median(redraw) / anchor:.2f}")
    result = None if args.no_browser else in_browser(args.points, args.edits)
    if result is None:
        print("browser: skipped (--no-browser, or no /usr/bin/chromium / playwright)")
    else:
        times, first = result
        print(f"browser round trip (Enter -> surface data changed in the page): median "
              f"{statistics.median(times) * 1e3:.1f} ms, max {max(times) * 1e3:.1f} ms over {len(times)} "
              f"edits (first edit {first * 1e3:.1f} ms)")
        summary += f" browser_ms={statistics.median(times) * 1e3:.1f}"
    print(summary)


if __name__ == "__main__":
    main()
