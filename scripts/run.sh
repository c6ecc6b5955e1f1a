#!/usr/bin/env bash
# The main job: builds if needed, then runs meshsmooth on its built-in default input
# (a noisy icosphere) and prints the validation report and metrics.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh dev
build/client/meshsmooth info builtin:noisy-sphere
