#!/usr/bin/env bash
# Installs the Debian 12 packages meshsmooth needs (only when one is missing), then configures
# and builds one CMake preset.
# Usage: scripts/setup.sh [dev|asan|fuzz|image|python] [--packages-only]   (default: dev)
# fuzz also installs clang, libFuzzer and LLVM's OpenMP runtime (clang's -fopenmp needs it).
# image is what docker/Dockerfile builds: only the packages that build the two binaries (no test
# or benchmark tools), preset dev with tests and benchmarks off, only meshsmoothd and meshsmooth.
# python installs the Python package for /usr/bin/python3 (docs/python.md): the packages that
# build the binaries and pybind11, preset python (build-python/), then
# `cmake --install build-python --component python` into /usr/local/lib/python3.X/dist-packages (X: python3's minor version).
# --packages-only installs the packages and stops (the Dockerfile does that in a layer of its own,
# which a rebuild after a source change reuses).
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-dev}"
packages_only=false
case "${2:-}" in
  "") ;;
  --packages-only) packages_only=true ;;
  *) echo "usage: scripts/setup.sh [dev|asan|fuzz|image|python] [--packages-only]" >&2; exit 2 ;;
esac

# What builds meshsmoothd and meshsmooth; the rest is for the tests, benchmarks and fuzzers.
packages=(
  build-essential cmake ninja-build pkgconf
  libgrpc++-dev libgrpc-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libdraco-dev libabsl-dev libcli11-dev libeigen3-dev libpng-dev prometheus-cpp-dev nlohmann-json3-dev
  libsqlite3-dev libssl-dev libpqxx-dev libcurl4-openssl-dev
)
# The Python package (python/): pybind11 and the headers of Debian's python3, numpy at run time.
if [ "$preset" != image ] && [ "$preset" != asan ] && [ "$preset" != fuzz ]; then
  packages+=(python3-pybind11 python3-dev python3-numpy)
fi
# python3-open3d: Open3D's Python module, for the test of meshsmooth.smooth_open3d (the package
# itself does not need it).
if [ "$preset" != image ] && [ "$preset" != python ]; then
  packages+=(
    grpc-proto draco libopenmesh-dev libgtest-dev libgmock-dev libbenchmark-dev libopen3d-dev libcgal-dev
    python3-grpcio python3-protobuf python3-numpy python3-scipy python3-yaml python3-open3d openssl
    nginx prometheus clang-format nodejs postgresql-15
  )
fi
# kubectl renders deploy/kubernetes in tests/deploy/kubernetes_test.py. Debian's is
# kubernetes-client; a kubectl already on PATH (from another package) is used as it is.
if [ "$preset" != image ] && [ "$preset" != python ] && ! command -v kubectl >/dev/null; then
  packages+=(kubernetes-client)
fi
if [ "$preset" = fuzz ]; then packages+=(clang libfuzzer-14-dev libomp-dev); fi
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  "${sudo_cmd[@]}" apt-get update -qq
  # Debian starts a packaged service as it installs it (nginx: a system daemon on port 80;
  # prometheus on 9090; postgresql-15 its cluster 15/main on 5432). The tests run their own, unprivileged; a policy-rc.d that refuses every
  # start keeps the system ones stopped (one already there, as in Debian's container images, is
  # left alone).
  if [ ! -e /usr/sbin/policy-rc.d ]; then
    printf '#!/bin/sh\nexit 101\n' | "${sudo_cmd[@]}" tee /usr/sbin/policy-rc.d >/dev/null
    "${sudo_cmd[@]}" chmod 755 /usr/sbin/policy-rc.d
    trap '"${sudo_cmd[@]}" rm -f /usr/sbin/policy-rc.d' EXIT
  fi
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq "${missing[@]}" >/dev/null
fi

$packages_only && exit 0

if [ "$preset" = image ]; then
  # build/ as preset dev, configured here only when new (as in the image's clean source tree).
  [ -f build/CMakeCache.txt ] || \
    cmake --preset dev -DMESHSMOOTH_BUILD_TESTS=OFF -DMESHSMOOTH_BUILD_BENCH=OFF >/dev/null
  cmake --build --preset dev --target meshsmoothd meshsmooth
  exit 0
fi
if [ "$preset" = python ]; then
  [ -f build-python/CMakeCache.txt ] || cmake --preset python >/dev/null
  cmake --build --preset python
  "${sudo_cmd[@]}" cmake --install build-python --component python
  exit 0
fi
build_dir=build
[ "$preset" = dev ] || build_dir="build-$preset"
# Configure once; later builds re-run CMake by themselves when a CMakeLists.txt changes.
[ -f "$build_dir/CMakeCache.txt" ] || cmake --preset "$preset" >/dev/null
cmake --build --preset "$preset"
