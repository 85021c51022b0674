#!/usr/bin/env bash
# Installs stemmap's build and run dependencies from Debian 12 packages. Idempotent.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config clang-format python3
  libopencv-dev libeigen3-dev libceres-dev
  libavcodec-dev libavformat-dev libavutil-dev libswscale-dev ffmpeg
  libnanoflann-dev libcli11-dev libfmt-dev libspdlog-dev nlohmann-json3-dev
  libgdal-dev libgtest-dev libgmock-dev libbenchmark-dev
  clang libclang-rt-14-dev libomp-dev  # the fuzz targets (scripts/fuzz.sh)
  chromium  # the report test renders the plot sheet headless
  parallel  # the batch test spreads a manifest with GNU parallel
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi
sudo_cmd=""
[ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo_cmd apt-get update -qq
$sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}"
