#!/usr/bin/env bash
# Builds the fuzz preset (clang + libFuzzer, ASan + UBSan; installs its packages if needed) and
# runs each fuzz target for SECONDS seconds, one after the other, in one process each.
#
# Usage: fuzz/run.sh [--no-build] [--seed N] SECONDS [TARGET...]
#   TARGET: fuzz_job fuzz_ply fuzz_obj fuzz_off fuzz_stl fuzz_drc fuzz_gltf (default: all). Draco
#     1.5.5's own glTF reader and writer crash on malformed files; the glTF path reads and writes
#     a file in a child process first (GltfScene::ReadInChildFirst), whose crash report says
#     whose frames crashed. fuzz_gltf logs a crash in Draco's frames (the line "glTF fuzz
#     target: ... Draco's glTF reader crashed on it (...)" and the child's report) and goes on;
#     a crash in meshsmooth's frames, or in frames that name neither, fails it like a crash of
#     the target itself
#   --no-build: run the binaries already in build-fuzz/ (e.g. a long run beside other builds)
#   --seed N: libFuzzer's random seed for every target (default: one from the clock). With a
#     fixed seed and the same corpus, a target makes the same mutations in the same order, so a
#     run repeats up to where its time runs out (CI fixes it; its corpora start empty).
#
# Seeds are written afresh to build-fuzz/fuzz-seeds/ (generated meshes and the small files of
# ${MESHSMOOTH_SHARED_DIR:-../shared}/data); what a run discovers accumulates in
# build-fuzz/fuzz-corpus/TARGET/. A crash, leak, timeout (> 25 s for one input) or
# out-of-memory (> 2 GB) leaves its input in build-fuzz/fuzz-findings/ and makes the script
# exit 1 once every target has run. One line per target sums the run up.
set -euo pipefail
cd "$(dirname "$0")/.."

usage="usage: fuzz/run.sh [--no-build] [--seed N] SECONDS [TARGET...]"
build=1
seed=
while [ $# -gt 0 ]; do
  case "$1" in
    --no-build) build=0; shift ;;
    --seed)
      [[ "${2:-}" =~ ^[1-9][0-9]*$ ]] || { echo "fuzz/run.sh: --seed needs a positive integer" >&2; exit 2; }
      seed="$2"; shift 2 ;;
    *) break ;;
  esac
done
seconds="${1:?$usage}"
shift
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_job fuzz_ply fuzz_obj fuzz_off fuzz_stl fuzz_drc fuzz_gltf)

[ "$build" = 0 ] || scripts/setup.sh fuzz
out=build-fuzz
shared="${MESHSMOOTH_SHARED_DIR:-../shared}"
rm -rf "$out/fuzz-seeds"
"$out/fuzz/fuzz_seeds" "$out/fuzz-seeds" "$shared"
mkdir -p "$out/fuzz-findings" "$out/fuzz-logs"

# One thread per job (LLVMFuzzerInitialize sets it too); UBSan reports stop the run.
export OMP_NUM_THREADS=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1

failed=()
for target in "${targets[@]}"; do
  format="${target#fuzz_}"
  seeds="$out/fuzz-seeds/$format"
  corpus="$out/fuzz-corpus/$target"
  log="$out/fuzz-logs/$target.log"
  mkdir -p "$corpus"
  args=(-max_total_time="$seconds" -timeout=25 -rss_limit_mb=2048 -print_final_stats=1
        -artifact_prefix="$out/fuzz-findings/$target-")
  [ -f "fuzz/$format.dict" ] && args+=(-dict="fuzz/$format.dict")
  [ -n "$seed" ] && args+=(-seed="$seed")
  # A job's time grows with its mesh: uploads up to car.drc's size (~70 KB), not the 120 KB
  # bunny whose mutants would otherwise fill the corpus at a tenth of the speed.
  [ "$target" = fuzz_job ] && args+=(-max_len=73728)
  status=ok
  start=$SECONDS
  "$out/fuzz/$target" "${args[@]}" "$corpus" "$seeds" >"$log" 2>&1 || status=FAILED
  elapsed=$((SECONDS - start))
  # libFuzzer's last status line (cov, ft, corp) and its final statistics: the last ones, since
  # a child of fuzz_gltf that libFuzzer's malloc limit stops prints statistics of its own.
  last=$(grep -E '^#[0-9]+' "$log" | tail -n 1 || true)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -n 1)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$last")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$last")
  corp=$(sed -n 's/.* corp: \([0-9]*\/[0-9]*[a-zA-Z]*\).*/\1/p' <<<"$last")
  used_seed=$(sed -n 's/^INFO: Seed: *//p' "$log" | head -n 1)
  echo "$target: $status, ${elapsed} s, executions ${execs:-?}, ${rate:-?} exec/s, cov ${cov:-?}, ft ${ft:-?}, corpus ${corp:-?}, seed ${used_seed:-?}"
  if [ "$status" != ok ]; then
    failed+=("$target")
    grep -E 'ERROR|SUMMARY|invariant violated|Test unit written' "$log" | head -n 5 | sed 's/^/  /'
    echo "  full log: $log"
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: findings in ${failed[*]} (inputs in $out/fuzz-findings/)"
  exit 1
fi
