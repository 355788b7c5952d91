#!/usr/bin/env python3
"""Browser test of the HTML reports, in headless Debian Chromium via chromedriver.

Opens reports/index.html and one run's index.html, and fails when
  - an image does not load (not complete, or zero natural width),
  - a link points to a file that does not exist or to an anchor that is not on the page,
  - anything is loaded from, or linked to, the network (http/https),
  - the page has Japanese text but not the bundled CJK font,
then saves a full-page screenshot of each page next to it (reports/index.png and
<run>/screenshot.png).

Usage: check_pages.py REPORTS_DIR RUN_DIR
"""
import json
import os
import sys
import urllib.parse
from pathlib import Path

from selenium import webdriver
from selenium.webdriver.chrome.service import Service


def driver(window_size="1280,900", console_log=False, downloads=None):
    """Headless Debian Chromium; with console_log, its console is kept for get_log("browser");
    with downloads (a folder), files the page downloads land there."""
    opts = webdriver.ChromeOptions()
    opts.binary_location = os.environ.get("CHROMIUM", "/usr/bin/chromium")
    for flag in [
        "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--allow-file-access-from-files", f"--window-size={window_size}", "--hide-scrollbars",
    ]:
        opts.add_argument(flag)
    if console_log:
        opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    if downloads is not None:
        opts.add_experimental_option("prefs", {"download.default_directory": str(downloads), "download.prompt_for_download": False})
    service = Service(executable_path=os.environ.get("CHROMEDRIVER", "/usr/bin/chromedriver"))
    d = webdriver.Chrome(service=service, options=opts)
    if downloads is not None:
        d.execute_cdp_cmd("Browser.setDownloadBehavior", {"behavior": "allow", "downloadPath": str(downloads)})
    return d


def verdict(result, problems, ok_line):
    """Prints the result as JSON, then FAIL with the number of problems (returns 1) or the
    one-line OK (returns 0): the end of every check here."""
    print(json.dumps(result, indent=2))
    if problems:
        print(f"FAIL: {len(problems)} problem(s)", file=sys.stderr)
        return 1
    print(ok_line)
    return 0


def check_page(d, page: Path, screenshot: Path):
    problems = []
    url = page.resolve().as_uri()
    d.get(url)
    # Wait until every image has finished loading or failing.
    d.execute_async_script("""
        const done = arguments[arguments.length - 1];
        const imgs = Array.from(document.images);
        Promise.all(imgs.map(i => i.complete ? null : new Promise(r => { i.onload = r; i.onerror = r; })))
            .then(() => done());
    """)
    # Japanese text (the Osafune joint names) needs the bundled CJK font: without it a plain
    # Chromium draws empty boxes.
    needs_cjk = d.execute_script(r"return /[\u2e80-\u9fff\uf900-\ufaff\uff00-\uffef]/.test(document.body.innerText);")
    if needs_cjk:
        loaded = d.execute_async_script("""
            const done = arguments[arguments.length - 1];
            document.fonts.load('16px "motionlab CJK"', '膝').then(f => done(f.length > 0), () => done(false));
        """)
        if not loaded:
            problems.append("the page has Japanese text but the bundled CJK font is not loaded")
    images = d.execute_script("return Array.from(document.images).map(i => [i.src, i.complete, i.naturalWidth]);")
    for src, complete, width in images:
        if not complete or width == 0:
            problems.append(f"image does not load: {src}")
    anchors = d.execute_script("return Array.from(document.querySelectorAll('a[href]')).map(a => a.href);")
    ids = set(d.execute_script("return Array.from(document.querySelectorAll('[id]')).map(e => e.id);"))
    for href in anchors:
        parsed = urllib.parse.urlparse(href)
        if parsed.scheme in ("http", "https"):
            problems.append(f"link to the network: {href}")
        elif parsed.scheme == "file":
            target = Path(urllib.parse.unquote(parsed.path))
            if not target.exists():
                problems.append(f"broken link: {href}")
            elif parsed.fragment and target.resolve() == page.resolve() and parsed.fragment not in ids:
                problems.append(f"anchor not on the page: #{parsed.fragment}")
        else:
            problems.append(f"unexpected link scheme: {href}")
    resources = d.execute_script("return performance.getEntriesByType('resource').map(e => e.name);")
    for r in resources:
        if not r.startswith("file:"):
            problems.append(f"loaded from the network: {r}")
    html = d.page_source
    for bad in ("http://", "https://"):
        for attr in ("src=\"" + bad, "href=\"" + bad):
            if attr in html:
                problems.append(f"page references the network ({attr}…)")
    # Full-page screenshot: grow the window to the document height.
    height = d.execute_script("return Math.min(document.body.scrollHeight, 20000);")
    d.set_window_size(1280, max(900, height))
    d.save_screenshot(str(screenshot))
    d.set_window_size(1280, 900)
    return {"page": str(page), "images": len(images), "links": len(anchors), "resources": len(resources), "problems": problems}


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    reports, run = Path(sys.argv[1]), Path(sys.argv[2])
    d = driver()
    try:
        results = [
            check_page(d, reports / "index.html", reports / "index.png"),
            check_page(d, run / "index.html", run / "screenshot.png"),
        ]
    finally:
        d.quit()
    print(json.dumps(results, indent=2))
    bad = [p for r in results for p in r["problems"]]
    if bad:
        print(f"FAIL: {len(bad)} problem(s)", file=sys.stderr)
        return 1
    print("browser test: OK ({} images, {} links checked)".format(sum(r["images"] for r in results), sum(r["links"] for r in results)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
