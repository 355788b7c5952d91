#!/usr/bin/env bash
# Rebuilds assets/NotoSansCJKjp-subset.otf: Noto Sans CJK JP Regular (SIL OFL 1.1, Debian package
# fonts-noto-cjk 1:20220127) cut down to the glyphs motionlab's pages and figures need — ASCII,
# the symbols the reports use, kana, and every CJK character of experiments/*.toml plus a fixed
# list of joint and gait words — so it can be embedded in a page (the full font is 19 MB).
# Usage: crates/motionlab-report/assets/subset_cjk_font.sh   (needs: apt-get install fonts-noto-cjk)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../../.." && pwd)
src=${NOTO_CJK:-/usr/share/fonts/opentype/noto/NotoSansCJK-Regular.ttc}
[ -f "$src" ] || { echo "missing $src: apt-get install fonts-noto-cjk" >&2; exit 1; }
venv="${TMPDIR:-/tmp}/motionlab-fonttools-venv"
[ -x "$venv/bin/pyftsubset" ] || { python3 -m venv "$venv"; "$venv/bin/pip" install --quiet fonttools==4.60.1; }
text=$(mktemp)
# Joint, body and gait vocabulary of motion-capture papers (Osafune et al. and the like), so a
# new experiment's Japanese names render without rebuilding the font.
vocab='頭首頸肩肘腕手指腰尻股膝脛足首踵趾爪先胸腹背骨盤脊椎鎖上下左右前後中央心重体幹肢関節角度回転屈曲伸展内外旋速遅歩行走通常正高低大小変化率平均標準偏差係数特徴量周期振幅姿勢位置関係被験者実験表図軸値正負合成制御分析'
python3 - "$repo" "$vocab" > "$text" <<'PY'
import sys, pathlib
repo, vocab = pathlib.Path(sys.argv[1]), sys.argv[2]
chars = set(chr(c) for c in range(0x20, 0x7f))
chars |= set("–—‘’“”…→←↑↓°²³×±≈≤≥≠μσΔ′″·•✔✘○△×")
chars |= set(chr(c) for c in range(0x3000, 0x3040))   # CJK punctuation
chars |= set(chr(c) for c in range(0x3041, 0x3097))   # hiragana
chars |= set(chr(c) for c in range(0x30a0, 0x3100))   # katakana
chars |= set(chr(c) for c in range(0xff01, 0xff5f))   # full-width forms
chars |= set(vocab)
for f in sorted((repo / "experiments").glob("*.toml")):
    chars |= {c for c in f.read_text(encoding="utf-8") if ord(c) >= 0x2e80}
print("".join(sorted(chars)))
PY
"$venv/bin/pyftsubset" "$src" --font-number=0 --text-file="$text" \
  --name-IDs='*' --notdef-outline --drop-tables+=vhea,vmtx,VORG \
  --output-file="$here/NotoSansCJKjp-subset.otf"
rm -f "$text"
ls -l "$here/NotoSansCJKjp-subset.otf"
