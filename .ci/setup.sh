#!/usr/bin/env bash
# One-step set-up for a fresh Debian 12 machine (root): installs the missing Debian packages,
# builds Firn (Release, CMake + Ninja) and then
#   .ci/setup.sh run    runs the default scene (scenes/default.toml)  -> out/default/
#   .ci/setup.sh test   runs the whole test suite (CTest)
# Idempotent and quiet when everything is already there.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake ninja-build libopenvdb-dev libopenvdb-tools libtbb-dev
          libeigen3-dev libblosc-dev libboost-iostreams-dev catch2 libtomlplusplus-dev
          libpng-dev libgdal-dev python3-matplotlib python3-numpy python3-openvdb ffmpeg blender
          mkdocs)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "installing: ${missing[*]}"
  sudo_cmd=""; [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
fi

jobs=$(nproc)
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j "$jobs"

case "${1:-run}" in
  run)  build/firn run scenes/default.toml ;;
  test) ctest --test-dir build --output-on-failure -j "$jobs" ;;
  *)    echo "usage: .ci/setup.sh [run|test]" >&2; exit 1 ;;
esac
