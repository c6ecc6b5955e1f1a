#!/usr/bin/env bash
# Checks that the shared data the tests read is there: every path of tests/shared_data.txt under
# the shared folder (MESHSMOOTH_SHARED_DIR, default ../shared beside the checkout). CI runs it
# before its tests (scripts/test.sh under CI=true), so a machine without the folder fails at once
# with the folder named, instead of passing with the tests that need it skipped.
# Usage: scripts/check-shared-data.sh   (exit 0: all there; 1: the folder or files missing)
set -euo pipefail
cd "$(dirname "$0")/.."
shared="${MESHSMOOTH_SHARED_DIR:-../shared}"
if [ ! -d "$shared/data" ]; then
  echo "check-shared-data: the shared data folder $(realpath -m "$shared/data") is absent;" \
    "the tests that read it would only skip (set MESHSMOOTH_SHARED_DIR to where it is)" >&2
  exit 1
fi
missing=()
while IFS= read -r path; do
  case "$path" in ""|"#"*) continue ;; esac
  [ -f "$shared/$path" ] || missing+=("$path")
done < tests/shared_data.txt
if [ ${#missing[@]} -gt 0 ]; then
  echo "check-shared-data: ${#missing[@]} files the tests read are missing from $(realpath -m "$shared"):" >&2
  printf '  %s\n' "${missing[@]}" >&2
  exit 1
fi
echo "check-shared-data: all $(grep -cvE '^(#|$)' tests/shared_data.txt) files the tests read are in $(realpath "$shared")"
