#!/usr/bin/env python3
"""Browser test of annotation mode on a segmentation viewer page, in headless Debian Chromium.

Opens VIEWER (a segmentation run's viewers/<sequence>.html of a real take) from the file system
with an empty browser profile and, with the page's own keys,
  - names the annotator, adds boundaries at the playhead (b), nudges one (. and shift+,),
    deletes the nearest (d), labels two (l, typing, Enter; one label with a comma and quotes),
    undoes and redoes the label (u, r), accepts the fused lane's candidate nearest the
    playhead (c);
  - checks the page's live judgement against every candidate lane: matched counts equal an
    independent maximum bipartite matching (augmenting paths) at the run's tolerance;
  - checks that leaving the page would ask first (its beforeunload handler cancels the event
    while marks are not downloaded, and no longer after the downloads), reloads, and finds
    the marks, the annotator and the count of changes not downloaded again (browser storage);
  - loads tests/fixtures/annotations/86_01.eaf (CMU 86_01's labels as an ELAN tier) as a second
    annotator;
  - downloads the marks as CSV and as ELAN .eaf, and reads both back through motionlab's own
    readers: a run of MOTIONLAB on the same motion file with four datasets — boundaries_csv
    with annotator = each annotator, elan_eaf with tier = each — whose ground truth (the run's
    files/segmentation_boundaries.json) must be exactly the frames marked (and, from the .eaf,
    the labels);
and fails on a console error, an error box, or anything loaded from the network. Saves a
screenshot of the page in annotation mode (SCREENSHOT, default <viewer>-annotate.png) and, with
KEEP_DIR set, the two downloaded files there.

Usage: check_annotate.py VIEWER MOTIONLAB [SCREENSHOT]
"""
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys

from check_pages import driver, verdict  # the same headless Chromium set-up (beside this file)

REPO = Path(__file__).resolve().parent.parent.parent
LOADERS = {"amc": "asf_amc", "bvh": "bvh", "c3d": "c3d", "tsv": "qualisys_tsv"}
# Whether leaving the page now would ask first: a cancelable beforeunload, cancelled.
WOULD_WARN = "const e = new Event('beforeunload', { cancelable: true }); window.dispatchEvent(e); return e.defaultPrevented;"


def max_matching(found, truths, tol):
    """Size of a maximum one-to-one matching |a − t| ≤ tol, by augmenting paths (Kuhn)."""
    partner = {}

    def augment(i, seen):
        for j, t in enumerate(truths):
            if abs(found[i] - t) <= tol and j not in seen:
                seen.add(j)
                if j not in partner or augment(partner[j], seen):
                    partner[j] = i
                    return True
        return False

    return sum(augment(i, set()) for i in range(len(found)))


def wait_for(d, script, what, timeout=15.0):
    end = time.time() + timeout
    while time.time() < end:
        v = d.execute_script(script)
        if v:
            return v
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


def wait_ready(d):
    wait_for(d, "return window.viewer && window.viewer.ready || document.getElementById('error').textContent !== ''", "the page")
    err = d.find_element(By.ID, "error").text
    if err:
        raise AssertionError(f"the page shows an error: {err}")


def marks(d):
    return d.execute_script("return window.viewer.annotation.marks")


def source_of(viewer: Path, sha: str, sequence: str) -> Path:
    """The run's input file with this SHA-256 (from its provenance), resolved like the run did."""
    prov = json.loads((viewer.parent.parent / "provenance.json").read_text())
    for f in prov["inputs"]:
        if f["sha256"] == sha:
            p = Path(f["path"])
            return p if p.is_absolute() else (REPO / p).resolve()
    raise AssertionError(f"no input of the run has SHA-256 {sha} ({sequence})")


def main():
    if len(sys.argv) not in (3, 4):
        print(__doc__)
        return 2
    page = Path(sys.argv[1]).resolve()
    motionlab = sys.argv[2]
    shot = Path(sys.argv[3]) if len(sys.argv) == 4 else page.with_name(page.stem + "-annotate.png")
    work = Path(tempfile.mkdtemp(prefix="motionlab-annotate-"))
    downloads = work / "downloads"
    downloads.mkdir()
    problems = []
    d = driver(window_size="1400,900", console_log=True, downloads=downloads)
    try:
        d.get(page.as_uri())
        wait_ready(d)
        spec = d.execute_script("return window.viewer.meta.annotation")
        if not spec:
            raise AssertionError("the page has no annotation mode (meta.annotation is null)")
        n_frames = d.execute_script("return window.viewer.meta.n_frames")
        rate = d.execute_script("return window.viewer.meta.frame_rate_hz")
        tol = spec["tolerance_frames"] or 0.0
        body = d.find_element(By.TAG_NAME, "body")
        key = lambda k: body.send_keys(k)

        # Annotation mode: the name field takes focus while there is no name.
        key("a")
        wait_for(d, "return window.viewer.annotation.on", "annotation mode")
        name = d.find_element(By.ID, "anno-name")
        name.send_keys("tester", Keys.ENTER)
        d.execute_script("document.activeElement.blur()")
        assert d.execute_script("return window.viewer.annotation.name") == "tester"

        def at(frame, *keys):
            d.execute_script("window.viewer.setPlaying(false); window.viewer.seek(arguments[0])", frame)
            for k in keys:
                key(k)

        at(600, "b")
        at(1200, "b")
        at(2000, "b", ".", ".", ".")           # 2003
        at(2003, Keys.SHIFT + ",")             # ten back: 1993
        at(1190, "d")                          # the nearest, 1200, goes
        frames = [m["frame"] for m in marks(d)]
        if frames != [600, 1993]:
            problems.append(f"after add, nudge and delete the marks are {frames}, expected [600, 1993]")

        def label(frame, text):
            at(frame, "l")
            box = d.find_element(By.ID, "anno-label-input")
            wait_for(d, "return document.activeElement && document.activeElement.id === 'anno-label-input'", "the label field")
            box.send_keys(Keys.CONTROL, "a", Keys.NULL, text, Keys.ENTER)

        label(600, "walk")
        label(1993, 'punch, "hard"')
        labels = {m["frame"]: m["label"] for m in marks(d)}
        if labels != {600: "walk", 1993: 'punch, "hard"'}:
            problems.append(f"labels {labels}")
        key("u")
        if {m["frame"]: m["label"] for m in marks(d)}[1993] != "":
            problems.append("undo did not take the last label back")
        key("r")
        if {m["frame"]: m["label"] for m in marks(d)}[1993] != 'punch, "hard"':
            problems.append("redo did not restore the label")

        # Accept the fused candidate nearest a frame away from the other marks.
        lanes = d.execute_script("return window.viewer.meta.lanes.filter(l => l.type === 'events').map(l => [l.name, l.kind, l.marks.map(m => m.frame)])")
        fused = next(l for l in lanes if l[1] == "fused")
        target = next(f for f in fused[2] if f > 2600 and f < n_frames - 2)
        d.execute_script("window.viewer.setActiveLane(window.viewer.meta.lanes.findIndex(l => l.kind === 'fused'))")
        at(target + 4, "c")
        expected = [600, 1993, target]
        got = [m["frame"] for m in marks(d)]
        if got != expected:
            problems.append(f"after accepting {fused[0]}'s candidate {target} the marks are {got}, expected {expected}")

        # The live judgement equals an independent maximum matching, lane by lane.
        results = d.execute_script("return window.viewer.annotation.results")
        for r in results:
            lane = next(l for l in lanes if l[0] == r["method"])
            want = max_matching(lane[2], expected, tol)
            if r["matched"] != want or r["found"] != len(lane[2]) or r["truths"] != len(expected):
                problems.append(f"live judgement of {r['method']}: {r['matched']} matched of {r['found']}, expected {want} of {len(lane[2])}")
        if len(results) != sum(1 for l in lanes if l[1] in ("candidates", "fused")):
            problems.append(f"{len(results)} lanes judged")
        if d.execute_script("return window.viewer.annotation.judgedAgainst") != fused[0]:
            problems.append("your marks are not coloured by the fused lane")
        pending = d.execute_script("return window.viewer.annotation.pending")
        if not d.find_element(By.ID, "anno-unsaved").is_displayed():
            problems.append("the page does not say that marks are not downloaded")

        # Leaving asks first: the page's beforeunload handler cancels the event (WebDriver
        # accepts the browser's dialog by itself, so the handler's answer is what is checked).
        if not d.execute_script(WOULD_WARN):
            problems.append("no warning before leaving the page with marks not downloaded")
        # Reload: everything comes back from the browser's storage.
        before = marks(d)
        d.refresh()
        wait_ready(d)
        after = marks(d)
        if after != before:
            problems.append(f"after a reload the marks are {after}, expected {before}")
        if not d.execute_script("return window.viewer.annotation.on") or d.execute_script("return window.viewer.annotation.name") != "tester":
            problems.append("after a reload annotation mode or the annotator's name is lost")
        if d.execute_script("return window.viewer.annotation.pending") != pending:
            problems.append("after a reload the count of changes not downloaded is lost")

        # Continue an existing truth: CMU 86_01's labels as an ELAN tier, a second annotator.
        fixture = REPO / "tests/fixtures/annotations/86_01.eaf"
        d.find_element(By.ID, "anno-load").send_keys(str(fixture))
        wait_for(d, "return window.viewer.annotation.marks.some(m => m.annotator === 'actions')", "the loaded tier")
        cmu = sorted(m["frame"] for m in marks(d) if m["annotator"] == "actions")
        if cmu != [549, 1149, 1979, 2499, 3199, 4064]:
            problems.append(f"the loaded tier gives {cmu}, expected CMU 86_01's boundaries")

        d.execute_script("window.viewer.seek(arguments[0])", 1993)
        time.sleep(0.2)
        d.save_screenshot(str(shot))

        # Both downloads.
        d.find_element(By.ID, "anno-csv").click()
        d.find_element(By.ID, "anno-eaf").click()
        seq = spec["sequence"]
        csv_file, eaf_file = downloads / f"{seq}.csv", downloads / f"{seq}.eaf"
        end = time.time() + 15
        while time.time() < end and not (csv_file.is_file() and eaf_file.is_file() and not list(downloads.glob("*.crdownload"))):
            time.sleep(0.1)
        if not (csv_file.is_file() and eaf_file.is_file()):
            raise AssertionError(f"downloads missing: {sorted(p.name for p in downloads.iterdir())}")
        if d.execute_script("return window.viewer.annotation.pending") != 0 or d.find_element(By.ID, "anno-unsaved").is_displayed():
            problems.append("after downloading, the page still counts changes as not downloaded")
        if d.execute_script(WOULD_WARN):
            problems.append("after downloading, leaving the page still asks first")
        if csv_file.read_text() != d.execute_script("return window.viewer.annotation.csv()"):
            problems.append("the downloaded CSV is not the page's text")

        resources = d.execute_script("return performance.getEntriesByType('resource').map(e => e.name);")
        problems += [f"loaded from the network: {r}" for r in resources if not r.startswith(("file:", "data:", "blob:"))]
        for entry in d.get_log("browser"):
            if entry["level"] == "SEVERE":
                problems.append(f"console error: {entry['message']}")
        final = marks(d)
    finally:
        d.quit()

    keep = os.environ.get("KEEP_DIR")
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        for f in (csv_file, eaf_file):
            (Path(keep) / f.name).write_bytes(f.read_bytes())

    # Read both files back through motionlab's readers: the ground truth of a run on the same
    # motion must be exactly the frames marked (and the .eaf's segments carry the labels).
    source = source_of(page, spec["input_sha256"], spec["sequence"])
    loader = LOADERS[source.name.split(".")[1] if source.name.endswith(".gz") else source.suffix[1:]]
    datasets = []
    for fmt, reader, key_name in [("csv", "boundaries_csv", "annotator"), ("eaf", "elan_eaf", "tier")]:
        for who in ("tester", "actions"):
            truth = csv_file if fmt == "csv" else eaf_file
            datasets.append(
                f'[[dataset]]\nname = "{fmt}_{who}"\nfiles = [{json.dumps(str(source))}]\nloader = {{ type = "{loader}" }}\n'
                f'ground_truth = {{ type = "{reader}", file = {json.dumps(str(truth))}, {key_name} = "{who}" }}\n'
            )
    experiment = work / "round_trip.toml"
    experiment.write_text(
        '[experiment]\nname = "annotation_round_trip"\ndescription = "the viewer\'s downloads read back as ground truth"\n\n'
        + "\n".join(datasets)
        + '\n[segmentation]\n\n[[segmentation.segmenter]]\ntype = "speed_minima"\n'
    )
    reports = work / "reports"
    run = subprocess.run([motionlab, "run", str(experiment), "--reports", str(reports), "--quiet", "--no-cache"], capture_output=True, text=True)
    if run.returncode != 0:
        raise AssertionError(f"motionlab run failed: {run.stderr}")
    run_dir = next(p for p in (reports / "annotation_round_trip").iterdir() if p.is_dir())
    kept = json.loads((run_dir / "files/segmentation_boundaries.json").read_text())
    by_name = {s["name"]: s for s in kept["sequences"]}
    checked = {}
    for fmt in ("csv", "eaf"):
        for who in ("tester", "actions"):
            truth = next(t for t in by_name[f"{fmt}_{who}"]["tiers"] if t["name"] == "truth")
            want = sorted((m["frame"], m["label"]) for m in final if m["annotator"] == who)
            got = [(m["frame"], m["label"]) for m in truth["marks"]]
            if [f for f, _ in got] != [f for f, _ in want]:
                problems.append(f"{fmt} read back for {who}: frames {[f for f, _ in got]}, marked {[f for f, _ in want]}")
            if fmt == "eaf" and got != want:
                problems.append(f"eaf read back for {who}: {got}, marked {want}")
            checked[f"{fmt}_{who}"] = len(got)

    result = {"page": str(page), "rate_hz": rate, "tolerance_frames": tol, "marks": final, "read_back": checked, "screenshot": str(shot), "problems": problems}
    return verdict(result, problems, f"annotation test: OK ({len(final)} marks of 2 annotators; CSV and .eaf read back to the same frames)")


if __name__ == "__main__":
    sys.exit(main())
