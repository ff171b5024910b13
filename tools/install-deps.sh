#!/usr/bin/env bash
# Installs what building and testing pkss needs on Debian/Ubuntu (apt).
# Used by tools/quickstart.sh and by CI (.ci/run).
# OpenCL: building needs the headers only (opencl-headers); libpkss
# dlopen()s the ICD loader (ocl-icd-libopencl1) at run time, and PoCL runs
# the kernels on the CPU. cargo (rustup, not apt) is optional: without it
# the Rust example of tools/run-tests.sh is skipped.
set -euo pipefail
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  cmake make gcc g++ clang pkg-config \
  opencl-headers ocl-icd-libopencl1 pocl-opencl-icd clinfo \
  liblapacke-dev libopenblas-dev libcmocka-dev \
  python3 python3-pip python3-venv python3-dev libusb-1.0-0 \
  >/dev/null
echo "pkss: build and test dependencies installed"
