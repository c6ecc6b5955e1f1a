#!/usr/bin/env bash
# Builds (installing packages if needed) and runs the whole test suite with ctest.
# Usage: scripts/test.sh [dev|asan]   (default: dev; asan = AddressSanitizer + UBSan build)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-dev}"
scripts/setup.sh "$preset"
ctest --preset "$preset" -j2
