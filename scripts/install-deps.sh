#!/usr/bin/env bash
# Installs every build and test dependency of linesight from Debian 12 packages.
# Idempotent: does nothing (and needs no network) when everything is already installed.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config git clang-format ccache
  libopencv-dev libopencv-contrib-dev opencv-doc
  libpng-dev libjpeg-dev  # PNG and JPEG read and written without OpenCV's imgcodecs (src/linesight/io/image_codecs.h)
  libeigen3-dev libceres-dev libboost-graph-dev libhwy-dev
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev libcpp-httplib-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  clang libclang-rt-14-dev  # libFuzzer targets (cmake -DLINESIGHT_FUZZ=ON, see src/linesight/io)
  python3-numpy python3-opencv
  python3-dev pybind11-dev python3-pytest  # the Python module (cmake -DLINESIGHT_PYTHON=ON) and its pytest suite
  slurm-wlm munge  # the batch command's Slurm array test (scripts/slurm_array_test.sh) on a one-node cluster
  dpkg-dev file  # CPack's .deb generator (dpkg-shlibdeps) on the package test
  chromium  # the base-station page's browser tests (src/linesight/server/page_browser_test.mjs)
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

# Node.js runs the browser tests (playwright-core needs 20 or newer); Debian's nodejs where none is installed.
command -v node >/dev/null || missing+=(nodejs npm)

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages present"
else
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  echo "install-deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# playwright-core from npm, at the version package-lock.json pins, into ./node_modules (it drives
# Debian's chromium; it never downloads a browser).
cd "$(dirname "$0")/.."
if [ ! -f node_modules/playwright-core/package.json ] || [ package-lock.json -nt node_modules/.package-lock.json ]; then
  echo "install-deps: npm ci (playwright-core)"
  npm ci --no-audit --no-fund --loglevel=error
fi
