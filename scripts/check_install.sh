#!/usr/bin/env bash
# Checks that an installed linesight can be built against: installs BUILD_DIR into WORK_DIR/prefix, builds
# examples/consumer with its CMake package (find_package(linesight)) and runs it on opencv-doc's Aloe pair,
# compiles and runs a program with its pkg-config file (pkg-config --static), then packs the Debian package with
# the build's CPack configuration and checks its control fields and that it holds the same files as the prefix.
#
# Usage: check_install.sh BUILD_DIR WORK_DIR   (BUILD_DIR: a configured and built tree; WORK_DIR: scratch)
# The Aloe pair is read from $LINESIGHT_OPENCV_DATA_DIR (default: opencv-doc's sample data). Exit 77 (skipped)
# without it, unless CI=true (then it is a failure).
set -euo pipefail
[ $# -eq 2 ] || { echo "usage: $0 BUILD_DIR WORK_DIR" >&2; exit 2; }
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "$1" && pwd)
data=${LINESIGHT_OPENCV_DATA_DIR:-/usr/share/doc/opencv-doc/examples/data}

log() { printf '[+%3ds] %s\n' "$SECONDS" "$*"; }
fail() { log "FAIL: $*"; exit 1; }
# Runs "${@:2}" with its output in the log file $1, shown when it fails.
quiet() {
  local out=$1; shift
  "$@" >"$out" 2>&1 || { tail -n 40 "$out"; fail "$* (log: $out)"; }
}

if [ ! -f "$data/aloeL.jpg" ] || [ ! -f "$data/aloeR.jpg" ]; then
  [ "${CI:-}" = true ] && fail "$data/aloe{L,R}.jpg not found (scripts/install-deps.sh installs opencv-doc)"
  echo "SKIP: $data/aloe{L,R}.jpg not found (Debian package opencv-doc, installed by scripts/install-deps.sh)"
  exit 77
fi
for tool in cmake cpack ninja g++ pkg-config dpkg-deb dpkg-shlibdeps; do
  command -v "$tool" >/dev/null || fail "$tool not found (scripts/install-deps.sh installs it)"
done
mkdir -p "$2"
work=$(cd "$2" && pwd)
prefix=$work/prefix
rm -rf "$prefix" "$work/consumer" "$work/deb"

log "install $build into $prefix"
quiet "$work/install.log" cmake --install "$build" --prefix "$prefix"
[ -x "$prefix/bin/linesight" ] || fail "no bin/linesight in $prefix"
# The installed headers are self-contained, and no installed file names the source or build tree.
grep -rhoE '#include "linesight/[^"]+"' "$prefix/include" | cut -d'"' -f2 | sort -u | while read -r header; do
  [ -f "$prefix/include/$header" ] || fail "an installed header includes $header, which is not installed"
done
if grep -rlF -e "$root" -e "$build" "$prefix/lib/cmake" "$prefix"/lib*/pkgconfig "$prefix"/lib/*/pkgconfig 2>/dev/null; then
  fail "the installed package files above name the build machine's folders"
fi

# With the Python module built (-DLINESIGHT_PYTHON=ON), the installed package imports from the prefix alone.
if compgen -G "$build/python/linesight/_core*.so" >/dev/null; then
  init=$(find "$prefix/lib" -path '*/dist-packages/linesight/__init__.py' | head -n 1)
  [ -n "$init" ] || fail "the Python package is not installed under $prefix/lib/python3*/dist-packages"
  site=$(dirname "$(dirname "$init")")
  out=$(cd "$work" && PYTHONPATH=$site /usr/bin/python3 -c \
    'import linesight; print(linesight.__file__, len(linesight.matchers()), "matchers")') ||
    fail "import linesight from $site failed"
  [[ $out == "$site/linesight/__init__.py "* ]] || fail "linesight was imported from elsewhere: $out"
  log "python: $out"
fi

log "installed CLI: sgbm-wls (OpenCV's ximgproc through the installed plugin)"
"$prefix/bin/linesight" disparity --method sgbm-wls --num-disp 64 --left "$data/aloeL.jpg" --right "$data/aloeR.jpg" \
  --out "$work/wls.pfm" >"$work/wls.log" 2>&1 || fail "the installed linesight could not run sgbm-wls: $(cat "$work/wls.log")"

log "consumer: find_package(linesight) from $prefix"
quiet "$work/consumer.log" cmake -S "$root/examples/consumer" -B "$work/consumer" -G Ninja \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix"
grep -qx "linesight_DIR:PATH=$prefix/lib.*/cmake/linesight" "$work/consumer/CMakeCache.txt" ||
  fail "the consumer did not find linesight in $prefix: $(grep linesight_DIR "$work/consumer/CMakeCache.txt")"
quiet "$work/consumer-build.log" cmake --build "$work/consumer" -j1
out=$("$work/consumer/disparity_density" "$data/aloeL.jpg" "$data/aloeR.jpg") || fail "disparity_density failed"
log "$out"
read -r density measured < <(sed -nE 's/^isgm density: ([0-9.]+) % \(measured: ([0-9.]+) %\)$/\1 \2/p' <<<"$out") ||
  fail "unexpected output: $out"
awk -v d="$density" -v m="$measured" 'BEGIN { exit !(d >= 90 && d <= 100 && m >= 60 && m <= d) }' ||
  fail "isgm density $density % (measured $measured %): expected >= 90 % filled, >= 60 % measured"

log "pkg-config: a program with \$(pkg-config --cflags --libs --static linesight)"
PKG_CONFIG_PATH=$(dirname "$(find "$prefix" -name linesight.pc)")
export PKG_CONFIG_PATH
cat >"$work/pkg_config_check.cc" <<'EOF'
// Reaches the top of the module graph (server, demo, eval), so the link line must hold every library in order.
#include <cstdio>

#include <linesight/demo/demo.h>
#include <linesight/eval/report.h>
#include <linesight/server/base_station.h>
#include <linesight/stereo/matcher.h>

int main() {
  std::printf("%zu matchers, default %s, %zu-byte page, demo %d, %s\n", linesight::MatcherNames().size(),
              linesight::DefaultMatcherName().c_str(), linesight::BaseStationPage().size(),
              linesight::RunDemo != nullptr, linesight::MachineDescription().c_str());
}
EOF
# shellcheck disable=SC2046  # pkg-config's flags are meant to be split
quiet "$work/pkg_config_check.log" g++ -O1 "$work/pkg_config_check.cc" -o "$work/pkg_config_check" \
  $(pkg-config --cflags --libs --static linesight)
log "$("$work/pkg_config_check")"

log "cpack -G DEB"
quiet "$work/cpack.log" cpack -G DEB --config "$build/CPackConfig.cmake" -B "$work/deb"
deb=$(find "$work/deb" -maxdepth 1 -name 'linesight_*.deb')
[ -f "$deb" ] || fail "no linesight_*.deb in $work/deb"
dpkg-deb --info "$deb" >"$work/deb-info.txt"
grep -E '^ (Package|Version|Depends):' "$work/deb-info.txt"
grep -q '^ Package: linesight$' "$work/deb-info.txt" || fail "package name is not linesight"
grep -q '^ Depends: .*libopencv-dev' "$work/deb-info.txt" || fail "Depends lacks the -dev packages"
grep -q '^ Depends: .*libc6' "$work/deb-info.txt" || fail "Depends lacks the CLI's shared libraries (dpkg-shlibdeps)"
# The package holds what `cmake --install` put in the prefix, under /usr.
dpkg-deb -c "$deb" | awk '$1 !~ /^d/ { print $6 }' | sed 's|^\./usr/||' | sort >"$work/deb-files.txt"
(cd "$prefix" && find . ! -type d | sed 's|^\./||' | sort) >"$work/prefix-files.txt"
diff "$work/prefix-files.txt" "$work/deb-files.txt" || fail "the .deb's files differ from the installed prefix"
for pattern in '^bin/linesight$' '^include/linesight/stereo/matcher\.h$' '^include/linesight/stereo/sgm_lanes-inl\.h$' \
  '^lib/(.*/)?liblinesight_core\.a$' '^lib/(.*/)?liblinesight_server\.a$' '^lib/(.*/)?cmake/linesight/linesightConfig\.cmake$' \
  '^lib/(.*/)?cmake/linesight/linesightTargets\.cmake$' '^lib/(.*/)?pkgconfig/linesight\.pc$' \
  '^lib/(.*/)?linesight/linesight_opencv_plugin\.so$'; do
  grep -qE "$pattern" "$work/deb-files.txt" || fail "the .deb has no file matching $pattern"
done
log "OK: $(wc -l <"$work/deb-files.txt") files in $(basename "$deb") ($(du -h "$deb" | cut -f1))"
