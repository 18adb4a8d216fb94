"""The rule designer driven in a real browser: `fuzzyfeed design` is started as a user starts it,
Debian's chromium (never a downloaded browser) opens it through Playwright, and the test drags a
breakpoint, changes a rule cell, watches the surface and the path feed change, breaks a rule,
saves, and checks the file with `fuzzyfeed rules check` and `rules diff`.

Skipped when /usr/bin/chromium or the playwright package is missing, unless
FUZZYFEED_REQUIRE_BROWSER=1 (CI), which turns the skip into a failure. FUZZYFEED_SCREENSHOT=FILE
writes the README's screenshot there (docs/designer.png)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fuzzyfeed.fuzzy.rule_reader import resolve_rules_path

CHROMIUM = "/usr/bin/chromium"
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--no-first-run", "--disable-sync"]
REQUIRE = os.environ.get("FUZZYFEED_REQUIRE_BROWSER") == "1"
PAPER = resolve_rules_path("paper")


def _browser_missing() -> str | None:
    if not Path(CHROMIUM).is_file():
        return f"{CHROMIUM} not installed (Debian package chromium)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the playwright package is not installed (pip install -e '.[test]')"
    return None


@pytest.fixture(scope="module")
def browser():
    missing = _browser_missing()
    if missing:
        if REQUIRE:
            pytest.fail(f"FUZZYFEED_REQUIRE_BROWSER=1 but {missing}")
        pytest.skip(missing)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        yield b
        b.close()


def _run(*args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "fuzzyfeed", *args], capture_output=True, text=True,
                          cwd=cwd, timeout=120)


@pytest.fixture
def app(tmp_path):
    """`fuzzyfeed design mine.toml --shape trident --no-browser` running; yields (url, file)."""
    table = tmp_path / "mine.toml"
    table.write_text(PAPER.read_text())
    proc = subprocess.Popen([sys.executable, "-m", "fuzzyfeed", "design", str(table), "--shape", "trident",
                             "--no-browser"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=tmp_path)
    line = proc.stdout.readline()
    m = re.search(r"http://127\.0\.0\.1:\d+/", line)
    if m is None:
        proc.kill()
        pytest.fail(f"no address printed: {line!r} {proc.stderr.read()!r}")
    yield m.group(0), table
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0 and "stopped (Ctrl-C)" in out, (out, err)


def _sum(page, name: str, column: str) -> float:
    return page.evaluate(f"""() => {{
        const d = Bokeh.documents[0].get_model_by_name('{name}').data['{column}'];
        const a = Array.isArray(d) && d.length && d[0].length !== undefined ? d[0] : d;
        let s = 0; for (const x of a) s += x; return s; }}""")


def _wait_change(page, name: str, column: str, before: float, timeout_ms: int = 30000) -> float:
    deadline = time.monotonic() + timeout_ms / 1000
    while time.monotonic() < deadline:
        now = _sum(page, name, column)
        if now != before:
            return now
        page.wait_for_timeout(20)
    raise AssertionError(f"{name}.{column} did not change within {timeout_ms} ms")


def _drag_breakpoint(page, variable: str, term: str, index: int, by_positions: float) -> None:
    """Press on the breakpoint's dot in the membership plot and move it along the axis."""
    box = page.evaluate(f"""() => {{
        const doc = Bokeh.documents[0];
        const view = Bokeh.index.find_one(doc.get_model_by_name('mf-{variable}'));
        const src = doc.get_model_by_name('mf-points-{variable}').data;
        let k = 0; while (!(src.term[k] == '{term}' && src.index[k] == {index})) k++;
        const r = view.canvas_view.el.getBoundingClientRect(), f = view.frame;
        return [r.left + f.x_scale.compute(src.x[k]), r.top + f.y_scale.compute(src.y[k]),
                r.left + f.x_scale.compute(src.x[k] + {by_positions})]; }}""")
    x0, y, x1 = box
    page.mouse.move(x0, y)
    page.mouse.down()
    for i in range(1, 9):
        page.mouse.move(x0 + (x1 - x0) * i / 8, y + 2)
    page.mouse.up()


def _screenshot(page, path: Path) -> None:
    """The top of the page as a 256-colour PNG (the README's picture, kept small)."""
    from PIL import Image

    raw = path.with_suffix(".raw.png")
    page.screenshot(path=str(raw), clip={"x": 0, "y": 0, "width": 1500, "height": 1080})
    with Image.open(raw) as im:
        im.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(path, optimize=True)
    raw.unlink()


LABELLED = """() => { const bad = [];
  const walk = (root) => { for (const el of root.querySelectorAll('*')) {
      const focusable = ['INPUT', 'SELECT', 'BUTTON', 'TEXTAREA', 'A'].includes(el.tagName) || el.tabIndex >= 0;
      if (focusable && el.tabIndex >= 0 && el.offsetParent !== null && !el.disabled) {
        const name = (el.labels && el.labels.length ? el.labels[0].textContent : '') ||
                     el.getAttribute('aria-label') || el.getAttribute('title') || el.textContent;
        if (!name.trim()) bad.push(el.outerHTML.slice(0, 80)); }
      if (el.shadowRoot) walk(el.shadowRoot); } };
  walk(document); return bad; }"""
FOCUSED = """() => { let e = document.activeElement;
  while (e && e.shadowRoot && e.shadowRoot.activeElement) e = e.shadowRoot.activeElement;
  return e && e.labels && e.labels.length ? e.labels[0].textContent.trim() : (e ? e.textContent.trim() : ''); }"""


def expect(locator):
    """Playwright's auto-waiting assertions (imported here: playwright is a test extra)."""
    from playwright.sync_api import expect as playwright_expect

    return playwright_expect(locator)


def test_design_in_the_browser(browser, app, tmp_path):
    url, table = app
    page = browser.new_page(viewport={"width": 1500, "height": 1080})
    page.goto(url)
    page.wait_for_function("() => window.Bokeh && Bokeh.documents.length && "
                           "Bokeh.documents[0].get_model_by_name('path-feed') && "
                           "Bokeh.documents[0].get_model_by_name('surface-image').data.image", timeout=90000)
    page.wait_for_timeout(500)

    # keyboard and screen reader basics: every control is named, Tab goes in reading order
    assert page.evaluate(LABELLED) == []
    page.get_by_label("Save to").focus()
    order = []
    for _ in range(40):
        page.keyboard.press("Tab")
        order.append(page.evaluate(FOCUSED))
    fields = [x for x in order if x.startswith("curvature ")]
    assert fields[:6] == ["curvature universe from", "curvature universe to", "curvature ZO a",
                          "curvature ZO b", "curvature ZO c", "curvature VS a"]
    assert order.index("Save") < order.index("Export FCL") < order.index("curvature universe from")

    surface0, feed0 = _sum(page, "surface-image", "image"), _sum(page, "path-feed", "feed")
    mean0 = page.locator(".ff-mean").inner_text()

    # drag the peak of curvature term B half-way to the next breakpoint: 0.2 -> 0.35 1/mm
    _drag_breakpoint(page, "curvature", "B", 1, 0.5)
    deadline = time.monotonic() + 30
    while page.get_by_label("curvature B b").input_value() != "0.35" and time.monotonic() < deadline:
        page.wait_for_timeout(50)
    assert page.get_by_label("curvature B b").input_value() == "0.35"
    surface1 = _wait_change(page, "surface-image", "image", surface0)
    feed1 = _wait_change(page, "path-feed", "feed", feed0)

    # change a rule cell: (curvature VS, curvature_variation L) VVHF -> LF
    page.get_by_label("rule: curvature VS, curvature_variation L").select_option("LF")
    surface2 = _wait_change(page, "surface-image", "image", surface1)
    _wait_change(page, "path-feed", "feed", feed1)
    assert surface2 < surface1                        # a slower rule lowers the surface
    assert page.locator(".ff-mean").inner_text() != mean0
    diff = page.locator(".ff-diff").inner_text()
    assert "curvature.B" in diff and "rule (curvature VS, curvature_variation L): VVHF -> LF" in diff

    # break a rule: VS's peak beyond its end; the message sits next to the field, Save is off
    field = page.get_by_label("curvature VS b")
    field.fill("0.09")
    field.press("Enter")
    error = page.locator(".ff-error").filter(has_text="breakpoints must be non-decreasing")
    error.first.wait_for(timeout=30000)
    assert "curvature.VS = [0.0, 0.09, 0.05]" in error.first.inner_text()
    expect(page.get_by_role("button", name="Save")).to_be_disabled(timeout=30000)
    assert _sum(page, "surface-image", "image") == surface2     # plots keep the last valid table
    if os.environ.get("FUZZYFEED_SCREENSHOT"):
        _screenshot(page, Path(os.environ["FUZZYFEED_SCREENSHOT"]))
    page.get_by_role("button", name="Undo").click()
    error.first.wait_for(state="detached", timeout=30000)
    # the button's state is its own message from the server: wait for it, as a user would
    expect(page.get_by_role("button", name="Save")).to_be_enabled(timeout=30000)

    # export: the download is `rules show --format fcl` of the draft (saved below)
    with page.expect_download() as download:
        page.get_by_role("button", name="Export FCL").click()
    exported = Path(download.value.path()).read_text()

    # save; the file passes rules check, and rules diff against the paper is the two edits
    page.get_by_role("button", name="Save").click()
    page.locator(".ff-saved").wait_for(timeout=30000)
    check = _run("rules", "check", str(table))
    assert check.returncode == 0 and check.stdout.startswith("ok: "), check
    diff = _run("rules", "diff", "paper", str(table))
    lines = [x.strip() for x in diff.stdout.splitlines()[1:]]
    assert lines == ["curvature.B: [0.10000000000000001, 0.20000000000000001, 0.5] -> "
                     "[0.10000000000000001, 0.34999999999999998, 0.5]",
                     "rule (curvature VS, curvature_variation L): VVHF -> LF"], diff.stdout
    comments = [x for x in PAPER.read_text().splitlines() if x.lstrip().startswith("#")]
    saved = table.read_text().splitlines()
    assert [x for x in saved if x.lstrip().startswith("#")] == comments
    assert exported == _run("rules", "show", str(table), "--format", "fcl").stdout

    # a file changed on disk since it was opened is not overwritten unasked
    elsewhere = table.read_text().replace("feed_floor_pct = 5.0", "feed_floor_pct = 6.0")
    table.write_text(elsewhere)
    page.get_by_label("rule: curvature ZO, curvature_variation ZO").select_option("VHF")
    page.get_by_role("button", name="Save").click()
    conflict = page.locator(".ff-conflict")
    conflict.wait_for(timeout=30000)
    assert "changed on disk since it was opened" in conflict.inner_text()
    assert "features.feed_floor_pct" in conflict.inner_text()       # what saving would undo
    assert table.read_text() == elsewhere
    page.get_by_role("button", name="Overwrite").click()
    deadline = time.monotonic() + 30
    while table.read_text() == elsewhere and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _run("rules", "show", str(table), "--format", "csv").stdout.splitlines()[1].split(",")[1] == "VHF"
    page.close()
