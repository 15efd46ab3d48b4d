#!/usr/bin/env bash
# Runs `linesight eval stereo` with bm and sgbm over every scene of a data folder and recomputes every figure
# independently with scripts/verify_metrics.py. Usage: check_eval_stereo.sh LINESIGHT DATA_DIR
# Exit 77 (skip) when the data folder is missing.
set -euo pipefail
bin=$1
data=$2
if [ ! -d "$data" ]; then
  echo "SKIP: $data not found (public stereo datasets, see README)"
  exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$bin" eval stereo --data "$data" --methods bm,sgbm --json "$work/report.json" \
  --save-disparity "$work/disp" >"$work/report.md"
/usr/bin/python3 "$(dirname "$0")/verify_metrics.py" --data "$data" --disparities "$work/disp" \
  --json "$work/report.json"
