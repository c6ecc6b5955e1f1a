#!/usr/bin/env bash
# Fails when a C++ file of the repository is not as clang-format (.clang-format: Google style,
# 120 columns) would write it, and lists those files. Fix with:
#   git ls-files '*.cc' '*.h' | xargs clang-format -i
set -euo pipefail
cd "$(dirname "$0")/.."
command -v clang-format >/dev/null || { echo "check-format: clang-format is not installed (apt-get install clang-format)" >&2; exit 2; }
bad=()
while IFS= read -r f; do
  if ! clang-format --dry-run --Werror "$f" >/dev/null 2>&1; then bad+=("$f"); fi
done < <(git ls-files '*.cc' '*.h')
if [ ${#bad[@]} -gt 0 ]; then
  echo "check-format: ${#bad[@]} file(s) differ from clang-format's output:"
  printf '  %s\n' "${bad[@]}"
  exit 1
fi
echo "check-format: every C++ file is clang-format clean"
