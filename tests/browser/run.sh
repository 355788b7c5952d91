#!/usr/bin/env bash
# Browser test of the HTML reports: needs Debian's chromium and chromium-driver.
# Usage: MOTIONLAB=path/to/motionlab tests/browser/run.sh REPORTS_DIR RUN_DIR [ODD_NAMES_REPORTS]
#   (exit 0 = pass, 1 = fail, 77 = skipped: no Chromium; .ci/run treats 77 as a failure)
# Checks reports/index.html and RUN_DIR/index.html (check_pages.py); with ODD_NAMES_REPORTS (the
# reports tests/odd_names.rs keeps when MOTIONLAB_KEEP_ODD_NAMES names a folder), that no odd name
# runs as markup on any of its pages (check_odd_names.py); then one viewer page
# (check_viewer.py): CMU 86_01 of sonoda_table1 (or the first found; none found fails);
# then annotation mode on that 86_01 page (check_annotate.py: keys, reload, downloads read back
# by a run of $MOTIONLAB); then the 13_29 matching viewer of the yabe_exercises run (a missing
# page fails) (screenshots beside the pages: the committed docs/ screenshots are copies).
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
"$venv/bin/python" "$here/check_pages.py" "$1" "$2"
if [ -n "${3:-}" ]; then
  "$venv/bin/python" "$here/check_odd_names.py" "$3"
fi
viewer=$( { ls "$1"/sonoda_table1/*/viewers/86_01.html 2>/dev/null; find "$1" -path '*/viewers/*.html' | sort; } | head -1 || true)
if [ -z "$viewer" ]; then
  echo "viewer test FAILED: no viewers/*.html under $1 (a reproduce writes them)"
  exit 1
fi
"$venv/bin/python" "$here/check_viewer.py" "$viewer"
annotate=$(ls "$1"/sonoda_table1/*/viewers/86_01.html 2>/dev/null | head -1 || true)
if [ -z "$annotate" ]; then
  echo "annotation test FAILED: no sonoda_table1/*/viewers/86_01.html under $1"
  exit 1
else
  motionlab=${MOTIONLAB:-$(command -v motionlab || true)}
  if [ -z "$motionlab" ] || [ ! -x "$motionlab" ]; then
    echo "annotation test FAILED: it reads the page's downloads back with motionlab; set MOTIONLAB to the binary"
    exit 1
  fi
  "$venv/bin/python" "$here/check_annotate.py" "$annotate" "$motionlab"
fi
matching=$(ls "$1"/yabe_exercises/*/viewers/13_29.html 2>/dev/null | head -1 || true)
if [ -z "$matching" ]; then
  echo "matching viewer test FAILED: no yabe_exercises/*/viewers/13_29.html under $1"
  exit 1
fi
exec "$venv/bin/python" "$here/check_viewer.py" "$matching"
