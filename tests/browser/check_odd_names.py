#!/usr/bin/env python3
"""Browser test of the odd-names run (docs/security.md), in headless Debian Chromium.

REPORTS_DIR holds the reports tests/odd_names.rs keeps when MOTIONLAB_KEEP_ODD_NAMES names it:
a run whose sequence, dataset, method and annotator names hold markup (`<script>`, `<img
onerror>`, `"><svg onload>`), `..`, `/`, Unicode, control characters and 300 characters. Each
payload, if it ran, would set `window.__motionlab_injected`.

Opens REPORTS_DIR/index.html, the run's page and every viewer page, and fails when
  - `window.__motionlab_injected` is set, or an element the payloads would create exists,
  - a page of check_pages.py's kind has a broken link or image (check_page: odd names must
    still link to their tables, figures and viewers),
  - a viewer shows its error box or logs a console error,
  - the run page or a viewer does not show the method name `<script>…</script>` as text.

Usage: check_odd_names.py REPORTS_DIR
"""
import json
import sys
import time
from pathlib import Path

from selenium.webdriver.common.by import By

from check_pages import check_page, driver

SCRIPT_NAME = "<script>window.__motionlab_injected=1</script>"

INJECTED = """
return {
  flag: window.__motionlab_injected === undefined ? null : String(window.__motionlab_injected),
  imgs: document.querySelectorAll('img[src="x"]').length,
  svgs: Array.from(document.querySelectorAll('svg[onload]')).length,
  scripts: Array.from(document.scripts).filter(s => s.textContent.includes('__motionlab_injected')).map(s => s.type || 'classic'),
};
"""


def injected(d):
    """What the payloads left in the page (nothing, when escaped)."""
    r = d.execute_script(INJECTED)
    problems = []
    if r["flag"] is not None:
        problems.append(f"window.__motionlab_injected = {r['flag']}: markup from a name ran")
    if r["imgs"] or r["svgs"]:
        problems.append(f"elements created from names: {r['imgs']} <img src=x>, {r['svgs']} <svg onload>")
    # The viewer's own data (type application/json) holds the names as JSON text; any other
    # script element holding the payload was injected.
    if [t for t in r["scripts"] if t != "application/json"]:
        problems.append(f"a script element holds a payload: {r['scripts']}")
    return problems


def main():
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    reports = Path(sys.argv[1])
    runs = sorted(p for p in (reports / "odd_names").iterdir() if p.is_dir())
    if not runs:
        print(f"FAIL: no odd_names run under {reports}", file=sys.stderr)
        return 1
    run = runs[-1]
    viewers = sorted((run / "viewers").glob("*.html"))
    # One viewer per sequence of the odd-names run (tests/odd_names.rs asserts the same count):
    # a run that wrote fewer would leave payloads unchecked.
    if len(viewers) != 8:
        print(f"FAIL: {len(viewers)} viewers under {run / 'viewers'}; expected 8", file=sys.stderr)
        return 1
    results = []
    d = driver(console_log=True)
    try:
        for page, shot in [(reports / "index.html", reports / "index.png"), (run / "index.html", run / "screenshot.png")]:
            r = check_page(d, page, shot)
            r["problems"] += injected(d)
            if page.parent == run and SCRIPT_NAME not in d.find_element(By.TAG_NAME, "body").text:
                r["problems"].append("the run page does not show the method name as text")
            results.append(r)
        for v in viewers:
            d.get(v.resolve().as_uri())
            for _ in range(300):
                if d.execute_script("return window.viewer && window.viewer.ready || document.getElementById('error').textContent !== ''"):
                    break
                time.sleep(0.02)
            problems = injected(d)
            error_box = d.find_element(By.ID, "error").text
            if error_box:
                problems.append(f"the viewer shows an error: {error_box}")
            if not d.execute_script("return !!(window.viewer && window.viewer.ready)"):
                problems.append("the viewer did not finish loading")
            if SCRIPT_NAME not in d.find_element(By.ID, "list").text:
                problems.append("the viewer's list does not show the method name as text")
            for entry in d.get_log("browser"):
                if entry["level"] == "SEVERE":
                    problems.append(f"console error: {entry['message']}")
            results.append({"page": str(v), "problems": problems})
    finally:
        d.quit()
    print(json.dumps(results, indent=2, ensure_ascii=False))
    bad = [p for r in results for p in r["problems"]]
    if bad:
        print(f"FAIL: {len(bad)} problem(s)", file=sys.stderr)
        return 1
    print(f"odd-names browser test: OK ({len(results)} pages, {len(viewers)} of them viewers; no name ran as markup)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
