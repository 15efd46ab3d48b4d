#!/usr/bin/env bash
# Syntax check of the base-station page's script (src/linesight/server/web/index.html) with Node.js:
# a JavaScript error would leave the page blank while every C++ test passes. Exit 77 (skipped)
# without node.
set -euo pipefail
page=${1:?usage: check_web_page.sh index.html}
command -v node >/dev/null || { echo "node not found: web page check skipped"; exit 77; }
tmp=$(mktemp --suffix=.js)
trap 'rm -f "$tmp"' EXIT
# The page has one inline <script> block.
sed -n '/<script>/,/<\/script>/p' "$page" | sed '1d;$d' >"$tmp"
[ -s "$tmp" ] || { echo "$page: no <script> block found"; exit 1; }
node --check "$tmp"
echo "$page: script parses ($(wc -l <"$tmp") lines)"
