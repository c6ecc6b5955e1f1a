#!/usr/bin/env bash
# A program linking only meshsmooth::core (core_only.cc) defines no operator new or delete of its
# own and carries no huge-page re-exec: both belong to meshsmooth::base, which a library user does
# not link. The same check on meshsmoothd must find both, so that this one can fail.
# Usage: check_core_only.sh CORE_ONLY_BINARY MESHSMOOTHD
set -euo pipefail
core_only=$1
server=$2
# Defined (not undefined) global operator new / delete, and the re-exec entry point.
ours() { nm -C --defined-only "$1" | grep -E ' (operator new|operator delete)\(|UseHugePagesForLargeBuffers' || true; }
found=$(ours "$core_only")
if [ -n "$found" ]; then
  echo "FAIL: $core_only links process-wide plumbing it should not:"; echo "$found"; exit 1
fi
in_server=$(ours "$server")
for want in 'operator new(unsigned long)' UseHugePagesForLargeBuffers; do
  if ! grep -qF "$want" <<<"$in_server"; then
    echo "FAIL: $server lacks $want (base not linked, or the check cannot see it)"; exit 1
  fi
done
"$core_only"
echo "ok: core alone has no operator new and no re-exec; meshsmoothd has both"
