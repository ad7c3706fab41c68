#!/usr/bin/env bash
# Installs the Debian 12 packages pardel builds, tests and plots with. Idempotent.
set -euo pipefail
pkgs=(build-essential cmake ninja-build pkg-config
      libginac-dev libcln-dev libeigen3-dev libomp-dev libboost-dev
      python3 python3-jinja2 python3-matplotlib python3-numpy python3-sympy
      python3-dev pybind11-dev python3-pybind11 python3-pytest
      python3-venv python3-setuptools python3-wheel
      libtomlplusplus-dev libcli11-dev nlohmann-json3-dev libfmt-dev libssl-dev
      libgtest-dev libgmock-dev libbenchmark-dev coinor-libipopt-dev
      libopenmpi-dev openmpi-bin clang-14 libclang-rt-14-dev
      python3-sphinx doxygen)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  sudo=""; [ "$(id -u)" -eq 0 ] || sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
