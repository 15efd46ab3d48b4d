#!/usr/bin/env bash
# The README's test command: installs every dependency, builds linesight with warnings as errors and runs the
# whole test suite. With CI=true it also checks formatting and runs the suite under ASan+UBSan.
# Idempotent; run from anywhere inside a clone.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
JOBS=${JOBS:-$(nproc)}

bash scripts/install-deps.sh

# ccache makes repeated builds (a second clone, the ASan build of unchanged code) cheap; BASEDIR makes its
# hits independent of where the clone lives.
# A fresh clone's headers are all "too new" for ccache's direct mode (it would preprocess every file
# to find its hit): mtime/ctime sloppiness lets the manifests hit directly.
export CCACHE_BASEDIR="$ROOT" CCACHE_NOHASHDIR=1 CCACHE_SLOPPINESS=include_file_mtime,include_file_ctime
LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)

if [ "${CI:-}" = "true" ]; then
  echo "== format check (clang-format, then git diff --exit-code) [$(date -u +%T)]"
  git ls-files '*.cc' '*.h' | xargs clang-format -i
  git diff --exit-code --stat || { echo "format check failed: run clang-format -i on the files above"; exit 1; }
fi

echo "== release build (warnings as errors) [$(date -u +%T)]"
cmake -S . -B build -G Ninja "${LAUNCHER[@]}" -DCMAKE_BUILD_TYPE=Release -DLINESIGHT_WERROR=ON \
  -DLINESIGHT_UNITY_BUILD=ON -DLINESIGHT_PYTHON=ON >/dev/null
cmake --build build -j"$JOBS"

echo "== tests [$(date -u +%T)]"
ctest --test-dir build --output-on-failure -j"$JOBS" --timeout 600

if [ "${CI:-}" = "true" ]; then
  echo "== ASan+UBSan build of the tests [$(date -u +%T)]"
  # -Og: every check of -O1's instrumentation at about 60 % of its compile time.
  cmake -S . -B build-asan -G Ninja "${LAUNCHER[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-Og -g1" \
    -DLINESIGHT_WERROR=ON -DLINESIGHT_UNITY_BUILD=ON -DLINESIGHT_SANITIZE=ON -DLINESIGHT_BUILD_BENCHMARKS=OFF >/dev/null
  cmake --build build-asan -j"$JOBS"
  echo "== tests under ASan+UBSan [$(date -u +%T)]"
  # Each test executable runs once (cmake/linesight_module.cmake). Left out under ASan (they run in the
  # release suite above): the `slow` label (end-to-end scripts, the browser and load tests), and accuracy
  # studies that repeat, on more data, code that the smaller tests already run under ASan -- two full
  # reconstruction-error calibrations, 20 noisy stereo calibrations, the calibration of OpenCV's 13
  # sample pairs, the bent-board calibration, the plate study over 6 cells, the CLI's range run
  # on a rendered plate pair (the plate study's chain), the insulator-string typing over six
  # frames (the line-obstacle test before it runs the same stages under ASan), the clean line's
  # inspection over seven frames (the rising line's and the bird-cage's tests run it) and the fault
  # study over a sequence (the damper and nest tests run its inspection, the sequence study its loop).
  ASAN_SKIP='LineObstaclesTest.AnInsulatorStringIsJoinedToItsClampAndTypedAsAString:ReconViewNoiseModel.*'
  ASAN_SKIP+=':ConductorFaultsTest.ACleanLineHasItsRadiusAndNoFault:FaultStudyTest.ScoresTiltedDampersWithTheDefects'
  ASAN_SKIP+=':CalibrateStereo.NoisyEstimateIsConsistentWithTheCramerRaoBound:CalibrateStereo.OpenCVSamplePairs'
  ASAN_SKIP+=':CalibrateStereo.ReconEstimatesTheBendOfABentBoard'
  ASAN_SKIP+=':PlateStudyTest.PhotographTexturedPlateAndBoxAreRangedWithinOnePercent'
  ASAN_SKIP+=':CliTest.RangeOnAnIndependentlyRenderedRectifiedPair'
  GTEST_FILTER="-$ASAN_SKIP" ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir build-asan --output-on-failure -j"$JOBS" --timeout 1800 -LE slow
fi
echo "== done [$(date -u +%T)]"
