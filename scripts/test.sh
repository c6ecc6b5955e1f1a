#!/usr/bin/env bash
# Builds (installing packages if needed) and runs the whole test suite with ctest.
# Usage: scripts/test.sh [dev|asan]   (default: dev; asan = AddressSanitizer + UBSan build)
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-dev}"
# CI has ../shared: without it the tests that read it would skip and CI pass without them.
if [ "${CI:-}" = true ]; then bash scripts/check-shared-data.sh; fi
scripts/setup.sh "$preset"
# --no-tests=error: a configure that left testing off fails here instead of passing with zero tests.
ctest --preset "$preset" -j2 --no-tests=error
