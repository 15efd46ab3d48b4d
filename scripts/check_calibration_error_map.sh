#!/usr/bin/env bash
# Checks scripts/calibration_error_map.py on calibrations whose answer is known: the true calibration of a
# rendered scene against itself (no error anywhere) and against a copy whose baseline is 1 % longer (every
# depth 1 % farther: the rectification and the disparities are unchanged, Z = f*B/d scales with B), plus a
# missing file (exit 2). Usage: check_calibration_error_map.sh LINESIGHT
set -euo pipefail
bin=$1
script="$(dirname "$0")/calibration_error_map.py"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$bin" render --obstacles none --supersampling 1 --out "$work/scene" >/dev/null
/usr/bin/python3 - "$work/scene/stereo.yml" "$work/longer.yml" <<'PY'
import sys, cv2
src, dst = sys.argv[1], sys.argv[2]
fs = cv2.FileStorage(src, cv2.FILE_STORAGE_READ)
out = cv2.FileStorage(dst, cv2.FILE_STORAGE_WRITE)
out.write("image_width", int(fs.getNode("image_width").real()))
out.write("image_height", int(fs.getNode("image_height").real()))
for key in ("M1", "D1", "M2", "D2", "R"):
    out.write(key, fs.getNode(key).mat())
out.write("T", fs.getNode("T").mat() * 1.01)
out.release()
PY
same=$(/usr/bin/python3 "$script" "$work/scene/stereo.yml" "$work/scene/stereo.yml" --at 100,50)
grep -q 'max |depth error|: 0.00 % overall' <<<"$same" || { echo "self-comparison is not 0: $same"; exit 1; }
longer=$(/usr/bin/python3 "$script" "$work/scene/stereo.yml" "$work/longer.yml" --depth 3 --at 100,50)
grep -q 'at (100, 50): depth error +1.00 %' <<<"$longer" || { echo "baseline +1 % not seen: $longer"; exit 1; }
grep -q 'max |depth error|: 1.00 % overall' <<<"$longer" || { echo "baseline +1 % not uniform: $longer"; exit 1; }
set +e
/usr/bin/python3 "$script" "$work/missing.yml" "$work/scene/stereo.yml" 2>"$work/err"
status=$?
set -e
[ "$status" -eq 2 ] && grep -q 'missing.yml' "$work/err" || { echo "missing file: exit $status"; exit 1; }
echo "calibration_error_map.py: 3 checks passed"
