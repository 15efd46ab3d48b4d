#!/usr/bin/env bash
# Runs the README's tour against a built CLI, so that every example in it is known to work: each ```sh block
# between the markers <!-- examples --> and <!-- /examples --> of README.md, command by command, in order, in a
# fresh temporary folder (the first example, `linesight demo --out out`, writes the files the later ones read).
# ```text blocks are synopses and are not run. Also fails when a subcommand that `linesight --help` or
# `linesight eval --help` lists has no example in the tour.
#
# Usage: check_readme.sh [BIN_DIR]   (BIN_DIR holds `linesight`; default $LINESIGHT_BIN_DIR, else build/apps of
#                                     this clone). EXAMPLE_TIMEOUT (seconds, default 300) bounds each command.
# Exit 77 (skipped) without opencv-doc's sample data, which the examples read.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
readme=$root/README.md
bin_dir=${1:-${LINESIGHT_BIN_DIR:-$root/build/apps}}
[ -x "$bin_dir/linesight" ] || { echo "check_readme.sh: no executable linesight in $bin_dir"; exit 1; }
bin_dir=$(cd "$bin_dir" && pwd)
export PATH="$bin_dir:$PATH"
opencv_data=/usr/share/doc/opencv-doc/examples/data
if [ ! -f "$opencv_data/aloeL.jpg" ]; then
  echo "SKIP: $opencv_data not found (Debian package opencv-doc, installed by scripts/install-deps.sh)"
  exit 77
fi

# The tour's blocks as NUL-separated records "sh<TAB>command" or "text<TAB>line"; backslash-continued lines are
# joined, blank lines and comment lines dropped.
extract() {
  awk '
    /^<!-- examples -->/ { inside = 1; next }
    /^<!-- \/examples -->/ { inside = 0; next }
    !inside { next }
    /^```/ {
      if (lang == "") { lang = substr($0, 4); if (lang == "") lang = "none"; cmd = ""; next }
      lang = ""; next
    }
    lang == "" { next }
    {
      line = $0
      if (cmd == "" && (line ~ /^[ \t]*$/ || line ~ /^[ \t]*#/)) next
      if (cmd != "") sub(/^[ \t]+/, "", line)
      if (line ~ /\\$/) { cmd = cmd substr(line, 1, length(line) - 1); next }
      cmd = cmd line
      printf "%s\t%s%c", lang, cmd, 0
      cmd = ""
    }
  ' "$readme"
}

mapfile -d '' records < <(extract)
[ "${#records[@]}" -gt 0 ] || { echo "check_readme.sh: no examples between <!-- examples --> markers in $readme"; exit 1; }

# Every subcommand needs an example (sh) or a synopsis (text) in the tour.
commands=$(linesight --help | sed -n '/^commands:/,$p' | awk 'NR > 1 && NF { print $1 }')
studies=$(linesight eval --help | sed -n '/^studies:/,$p' | awk 'NR > 1 && NF { print "eval " $1 }')
tour=$(printf '%s\n' "${records[@]}" | cut -f2-)
missing=()
while IFS= read -r name; do
  [ -z "$name" ] || [ "$name" = eval ] && continue
  grep -qE "(^|[;&|( ])linesight $name( |$)" <<<"$tour" || missing+=("$name")
done <<<"$commands"$'\n'"$studies"
if [ "${#missing[@]}" -gt 0 ]; then
  echo "check_readme.sh: README.md's tour has no example of: $(printf '%s, ' "${missing[@]}" | sed 's/, $//')"
  exit 1
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
echo "== README examples in $work with $(command -v linesight)"
start=$SECONDS
count=0
for record in "${records[@]}"; do
  lang=${record%%$'\t'*}
  cmd=${record#*$'\t'}
  [ "$lang" = sh ] || continue
  count=$((count + 1))
  echo "+ $cmd"
  t0=$SECONDS
  if ! timeout "${EXAMPLE_TIMEOUT:-300}" bash -euo pipefail -c "$cmd" </dev/null >"$work/example.log" 2>&1; then
    tail -n 20 "$work/example.log"
    echo "FAILED: README example $count: $cmd"
    exit 1
  fi
  echo "  ok ($((SECONDS - t0)) s)"
done
echo "== all $count README examples passed in $((SECONDS - start)) s"
