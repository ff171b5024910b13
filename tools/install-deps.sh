#!/usr/bin/env bash
# Installs what building and testing pkss needs on Debian/Ubuntu (apt).
# Used by tools/quickstart.sh and by CI (.ci/run).
set -euo pipefail
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  cmake make gcc g++ clang pkg-config \
  ocl-icd-opencl-dev opencl-headers pocl-opencl-icd clinfo \
  liblapacke-dev libopenblas-dev libcmocka-dev \
  python3 python3-pip python3-venv python3-dev libusb-1.0-0 \
  >/dev/null
echo "pkss: build and test dependencies installed"
