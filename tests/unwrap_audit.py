#!/usr/bin/env python3
"""Lists every unwrap()/expect(/panic!/unreachable!/todo!/unimplemented! in the non-test code
of crates/*/src (skipping `#[cfg(test)]` modules, the files they declare, comments and the
dev-only test-support crate motionlab-testkit) and
fails when a file holds more of them than docs/unwrap-audit.md lists for it.
Run: python3 tests/unwrap_audit.py
"""

import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
PATTERN = re.compile(r"\.unwrap\(\)|\.expect\(|panic!\(|unreachable!\(|todo!\(|unimplemented!\(")


def test_only_files() -> set:
    """Files declared as `#[cfg(test)] mod name;`."""
    out = set()
    for f in ROOT.glob("crates/*/src/**/*.rs"):
        for m in re.finditer(r"#\[cfg\(test\)\]\s*(?:pub\s+)?mod\s+(\w+)\s*;", f.read_text()):
            d = f.parent if f.name in ("mod.rs", "lib.rs", "main.rs") else f.parent / f.stem
            out |= {d / f"{m.group(1)}.rs", d / m.group(1) / "mod.rs"}
    return out


# The test-support crate is a dev-dependency only (synthetic motions and helpers that read a
# test's own outputs): a panic there is a failing test, never a user's input.
TEST_SUPPORT_CRATES = {"motionlab-testkit"}


def sites():
    skip_files = test_only_files()
    for f in sorted(ROOT.glob("crates/*/src/**/*.rs")):
        if f in skip_files or f.relative_to(ROOT).parts[1] in TEST_SUPPORT_CRATES:
            continue
        depth, skip_above, cfg_test = 0, None, False
        for i, line in enumerate(f.read_text().split("\n"), 1):
            s = line.strip()
            if s.startswith("#[cfg(test)]"):
                cfg_test = True
            if cfg_test and re.search(r"\b(mod|fn)\b", s) and "{" in line:
                skip_above, cfg_test = depth, False
            depth += line.count("{") - line.count("}")
            if skip_above is not None:
                if depth <= skip_above:
                    skip_above = None
                continue
            if s.startswith("//"):
                continue
            if PATTERN.search(line):
                yield f"{f.relative_to(ROOT)}:{i}", s


def main() -> int:
    audit = (ROOT / "docs/unwrap-audit.md").read_text()
    found = list(sites())
    for where, code in found:
        print(f"{where}: {code}")
    # Compared per file, not per line number, so unrelated edits that move a listed site do
    # not fail the check: a file may hold at most as many sites as the audit lists for it.
    failed = False
    for file in sorted({w.rsplit(":", 1)[0] for w, _ in found}):
        n_found = sum(1 for w, _ in found if w.rsplit(":", 1)[0] == file)
        n_listed = audit.count(f"`{file}:")
        if n_found > n_listed:
            failed = True
            print(f"{file}: {n_found} sites, docs/unwrap-audit.md lists {n_listed}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
