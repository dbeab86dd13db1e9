#!/usr/bin/env bash
# Installs the Debian packages heliar needs (as root, or through sudo when there is one).
#   bash tools/setup.sh           the main job: Mesa's software GPU drivers (lavapipe, llvmpipe)
#   bash tools/setup.sh --tests   also OpenCV 4.6 with clang (feature `opencv`: video, cameras,
#                                 the calibration tool), python3 (the behaviour check) and
#                                 python3-venv (tools/pytest.sh: the Python package's tests)
# Packages already installed are left alone, so a second run needs no network.
set -euo pipefail
pkgs="mesa-vulkan-drivers libegl1 libgl1-mesa-dri"
if [ "${1:-}" = "--tests" ]; then
  pkgs="$pkgs libopencv-dev clang libclang-dev python3 python3-venv"
fi
if dpkg -s $pkgs >/dev/null 2>&1; then
  exit 0
fi
as_root=""
if [ "$(id -u)" -ne 0 ]; then
  as_root="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$as_root apt-get update -qq
$as_root apt-get install -y -qq --no-install-recommends $pkgs >/dev/null
