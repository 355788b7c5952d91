#!/usr/bin/env bash
# Creates examples/external-segmenter/.venv with numpy (pinned like bench/requirements.txt) and
# prints its python. Idempotent. The tests read it from MOTIONLAB_TEST_PYTHON:
#   MOTIONLAB_TEST_PYTHON=$(examples/external-segmenter/setup_venv.sh) cargo test -p motionlab-external
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
venv="$here/.venv"
[ -x "$venv/bin/python" ] || python3 -m venv "$venv" >&2
if ! "$venv/bin/python" -c 'import numpy' 2>/dev/null; then
  "$venv/bin/pip" install --quiet --disable-pip-version-check -r "$here/requirements.txt" >&2
fi
echo "$venv/bin/python"
