#!/usr/bin/env bash
# Creates bench/.venv with the pinned Python peers (scipy, dtaidistance, tslearn, numpy, ruptures,
# ezc3d, c3d).
# Idempotent: does nothing when the venv already satisfies requirements.txt.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
venv="$here/.venv"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
if ! "$venv/bin/python" - "$here/requirements.txt" <<'PY' 2>/dev/null; then
import sys
from importlib.metadata import version
for line in open(sys.argv[1]):
    line = line.split('#')[0].strip()
    if not line:
        continue
    name, want = line.split('==')
    assert version(name) == want, name
PY
  "$venv/bin/pip" install --quiet --disable-pip-version-check -r "$here/requirements.txt"
fi
echo "$venv/bin/python"
