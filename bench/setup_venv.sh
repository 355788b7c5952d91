#!/usr/bin/env bash
# Creates bench/.venv with the pinned Python peers (scipy, dtaidistance, tslearn, numpy, ruptures,
# ezc3d, c3d). `setup_venv.sh requirements-NAME.txt` creates bench/.venv-NAME from that file
# instead (peers whose pins conflict with the main set: claspy needs numpy < 2.3).
# Idempotent: does nothing when the venv already satisfies its requirements file.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
requirements="${1:-requirements.txt}"
name="${requirements#requirements}"
venv="$here/.venv${name%.txt}"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
if ! "$venv/bin/python" - "$here/$requirements" <<'PY' 2>/dev/null; then
import sys
from importlib.metadata import version
for line in open(sys.argv[1]):
    line = line.split('#')[0].strip()
    if not line:
        continue
    name, want = line.split('==')
    assert version(name) == want, name
PY
  "$venv/bin/pip" install --quiet --disable-pip-version-check -r "$here/$requirements"
fi
echo "$venv/bin/python"
