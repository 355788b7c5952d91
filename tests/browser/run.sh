#!/usr/bin/env bash
# Browser test of the HTML reports: needs Debian's chromium and chromium-driver.
# Usage: tests/browser/run.sh REPORTS_DIR RUN_DIR   (exit 0 = pass, 1 = fail, 77 = skipped)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
chromium=${CHROMIUM:-/usr/bin/chromium}
driver=${CHROMEDRIVER:-/usr/bin/chromedriver}
if [ ! -x "$chromium" ] || [ ! -x "$driver" ]; then
  echo "browser test SKIPPED: $chromium or $driver not found (apt-get install chromium chromium-driver)"
  exit 77
fi
venv="$here/.venv"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check -r "$here/requirements.txt"
exec "$venv/bin/python" "$here/check_pages.py" "$1" "$2"
