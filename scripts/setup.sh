#!/usr/bin/env bash
# Installs the Debian 12 packages meshsmooth needs (only when one is missing), then configures
# and builds one CMake preset. Usage: scripts/setup.sh [dev|asan|fuzz]   (default: dev)
# fuzz also installs clang, libFuzzer and LLVM's OpenMP runtime (clang's -fopenmp needs it).
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-dev}"

packages=(
  build-essential cmake ninja-build pkgconf
  libgrpc++-dev libgrpc-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler grpc-proto
  libdraco-dev draco libopenmesh-dev libabsl-dev libgtest-dev libgmock-dev
  libcli11-dev libeigen3-dev libbenchmark-dev libpng-dev
  python3-grpcio python3-protobuf python3-numpy python3-scipy python3-yaml openssl
  nginx
)
if [ "$preset" = fuzz ]; then packages+=(clang libfuzzer-14-dev libomp-dev); fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  # Debian starts a packaged service as it installs it (nginx: a system daemon on port 80). The
  # tests run nginx of their own, unprivileged; a policy-rc.d that refuses every start keeps the
  # system one stopped (one already there, as in Debian's container images, is left alone).
  if [ ! -e /usr/sbin/policy-rc.d ]; then
    printf '#!/bin/sh\nexit 101\n' | "${sudo_cmd[@]}" tee /usr/sbin/policy-rc.d >/dev/null
    "${sudo_cmd[@]}" chmod 755 /usr/sbin/policy-rc.d
    trap '"${sudo_cmd[@]}" rm -f /usr/sbin/policy-rc.d' EXIT
  fi
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq "${missing[@]}" >/dev/null
fi

build_dir=build
[ "$preset" = dev ] || build_dir="build-$preset"
# Configure once; later builds re-run CMake by themselves when a CMakeLists.txt changes.
[ -f "$build_dir/CMakeCache.txt" ] || cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset"
