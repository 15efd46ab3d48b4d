#!/usr/bin/env bash
# The README's main command: installs every dependency, builds linesight and runs the main job,
# `linesight demo` on the embedded synthetic power-line scene.
# Idempotent; run from anywhere inside a clone. Output goes to ./out (or $OUT).
set -euo pipefail
cd "$(dirname "$0")/.."
JOBS=${JOBS:-$(nproc)}
OUT=${OUT:-out}

bash scripts/install-deps.sh
export CCACHE_BASEDIR="$(pwd)" CCACHE_NOHASHDIR=1
cmake -S . -B build -G Ninja -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$JOBS" --target linesight
mkdir -p "$OUT"
./build/apps/linesight demo --out "$OUT"
