#!/usr/bin/env bash
# Set up greybench on Debian 12 and open it or test it.
#   scripts/dev.sh open [PROJECT]   install what is missing, build, open the workbench
#   scripts/dev.sh test             install what is missing, build, run the whole test suite
#   scripts/dev.sh build            install what is missing and build only
# Packages come from Debian only; nothing is downloaded at build time.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  build-essential cmake ninja-build pkg-config python3 git
  libeigen3-dev libnlopt-cxx-dev nlohmann-json3-dev libcli11-dev libfmt-dev libboost-math-dev
  libsundials-dev
  libglfw3-dev libgl-dev libimgui-dev libosmesa6-dev libstb-dev fonts-dejavu-core
  libgtest-dev libgmock-dev libbenchmark-dev xvfb xauth
)

install_missing() {
  local missing=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "greybench: installing ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# A fresh build compiles the tests, ui/ and the CLI in unity batches (GREYBENCH_UNITY, about a
# quarter less compile time), and core/ too (GREYBENCH_UNITY_CORE, 40 % less there);
# GREYBENCH_CMAKE_ARGS="-DGREYBENCH_UNITY=OFF -DGREYBENCH_UNITY_CORE=OFF" builds file by file.
build() {
  cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DGREYBENCH_UNITY=ON \
    -DGREYBENCH_UNITY_CORE=ON ${GREYBENCH_CMAKE_ARGS:-}
  cmake --build build -j "$(nproc)"
}

command=${1:-open}
case "$command" in
  open)
    install_missing
    build
    shift || true
    exec build/app/greybench "$@"
    ;;
  test)
    install_missing
    build
    ctest --test-dir build --output-on-failure -j "$(nproc)" --timeout 600
    ;;
  build)
    install_missing
    build
    ;;
  *)
    echo "usage: scripts/dev.sh open [PROJECT] | test | build" >&2
    exit 2
    ;;
esac
