#!/usr/bin/env python3
"""Browser test of a viewer page, in headless Debian Chromium via chromedriver.

Opens VIEWER (a run's viewers/<sequence>.html) from the file system and fails when
  - the browser console reports an error, or the page shows its error box,
  - the 3-D canvas or the lanes canvas is blank (one colour only),
  - pressing "n" does not move the playhead to the next mark of the chosen lane (read from
    the page's own data), "p" does not move it back, or →/← do not step one frame,
  - anything is loaded from the network,
then saves a screenshot (SCREENSHOT, default <viewer>.png) and prints the page's size and open
time: navigation start → first frame drawn, as the page measures it, and wall time of the load.

Usage: check_viewer.py VIEWER [SCREENSHOT]
"""
import sys
import time
from pathlib import Path

from selenium.webdriver.common.by import By

from check_pages import driver, verdict  # the same headless Chromium set-up (beside this file)


# Distinct colours in a canvas, sampled on a grid (a blank canvas has one).
DISTINCT_COLOURS = """
const c = document.getElementById(arguments[0]);
const ctx = c.getContext('2d');
const d = ctx.getImageData(0, 0, c.width, c.height).data;
const seen = new Set();
const step = Math.max(1, Math.floor(c.width * c.height / 40000));
for (let i = 0; i < c.width * c.height; i += step) seen.add((d[4*i] << 16) | (d[4*i+1] << 8) | d[4*i+2] | (d[4*i+3] << 24));
return seen.size;
"""


def main():
    if len(sys.argv) not in (2, 3):
        print(__doc__)
        return 2
    page = Path(sys.argv[1]).resolve()
    shot = Path(sys.argv[2]) if len(sys.argv) == 3 else page.with_suffix(".png")
    problems = []
    d = driver(window_size="1400,900", console_log=True)
    try:
        started = time.perf_counter()
        d.get(page.as_uri())
        for _ in range(300):
            if d.execute_script("return window.viewer && window.viewer.ready || document.getElementById('error').textContent !== ''"):
                break
            time.sleep(0.02)
        wall_ms = (time.perf_counter() - started) * 1000
        error_box = d.find_element(By.ID, "error").text
        if error_box:
            problems.append(f"the page shows an error: {error_box}")
        open_ms = d.execute_script("return window.viewer.openMs")
        phases = d.execute_script("return window.viewer.phases")
        state = d.execute_script("""
            const v = window.viewer, l = v.meta.lanes[v.activeLane];
            return {frame: v.frame, lane: l ? l.name : null, marks: l ? l.marks.map(m => m.frame) : [],
                    n_frames: v.meta.n_frames};
        """)
        for canvas in ("scene", "lanes"):
            n = d.execute_script(DISTINCT_COLOURS, canvas)
            if n < 3:
                problems.append(f"canvas #{canvas} is blank ({n} colour(s))")
        body = d.find_element(By.TAG_NAME, "body")
        marks = state["marks"]
        if not marks:
            problems.append(f"the chosen lane {state['lane']!r} has no marks to step through")
        else:
            frame = state["frame"]
            expected = [f for f in marks if f > frame][:2]
            for want in expected:
                body.send_keys("n")
                got = d.execute_script("return window.viewer.frame")
                shown = d.find_element(By.ID, "readout").get_attribute("data-frame")
                if got != want or shown != str(want):
                    problems.append(f"'n' moved the playhead to {got} (readout {shown}), expected the next mark at {want}")
            if len(expected) == 2:
                body.send_keys("p")
                got = d.execute_script("return window.viewer.frame")
                if got != expected[0]:
                    problems.append(f"'p' moved the playhead to {got}, expected the previous mark at {expected[0]}")
            before = d.execute_script("return window.viewer.frame")
            body.send_keys("\ue014")  # →
            after = d.execute_script("return window.viewer.frame")
            if after != min(before + 1, state["n_frames"] - 1):
                problems.append(f"→ moved the playhead from {before} to {after}")
            body.send_keys("\ue012")  # ←
        resources = d.execute_script("return performance.getEntriesByType('resource').map(e => e.name);")
        problems += [f"loaded from the network: {r}" for r in resources if not r.startswith(("file:", "data:", "blob:"))]
        # Show a marked frame in the screenshot: the first matched mark of the chosen lane, if any.
        d.execute_script("""
            const v = window.viewer, l = v.meta.lanes[v.activeLane];
            const m = l && (l.marks.find(m => m.status === 'matched') || l.marks[0]);
            if (m) v.seek(m.frame);
        """)
        time.sleep(0.2)
        for entry in d.get_log("browser"):
            if entry["level"] == "SEVERE":
                problems.append(f"console error: {entry['message']}")
        d.save_screenshot(str(shot))
    finally:
        d.quit()
    result = {
        "page": str(page), "bytes": page.stat().st_size, "frames": state["n_frames"],
        "open_ms_in_page": round(open_ms, 1) if open_ms else None, "open_ms_wall": round(wall_ms, 1), "phases_ms": phases,
        "lane": state["lane"], "marks": len(marks), "screenshot": str(shot), "problems": problems,
    }
    return verdict(result, problems, f"viewer test: OK ({page.name}: {result['bytes'] / 1e6:.2f} MB, opened in {result['open_ms_in_page']} ms)")


if __name__ == "__main__":
    sys.exit(main())
