#!/usr/bin/env bash
# libFuzzer runs of the targets in fuzz/ (README "Reliability: sanitizers and fuzzing"):
#   scripts/fuzz.sh TARGET SECONDS   e.g. scripts/fuzz.sh obj 60 (or fuzz_obj)
#   scripts/fuzz.sh all SECONDS      every target, SECONDS each
#   scripts/fuzz.sh list             the targets
# Builds build-fuzz/ with clang (SPLITRAY_FUZZ=ON: libFuzzer, ASan, UBSan), replays the
# target's fuzz/regressions/<target>/ files (each must pass), then fuzzes for SECONDS from the
# seeds in fuzz/corpus/<target>/ (left unchanged: new inputs go to build-fuzz/corpus/<target>/).
# A finding (crash, leak, UB, an exception other than splitray::Error, a failed oracle, an
# input slower than 10 s or taking more than 2 GB) is written to build-fuzz/findings/<target>/
# and the script exits non-zero. KEEP_GOING=1 fuzzes on past findings (libFuzzer's fork mode)
# and collects them all. JOBS (default 2) sets the build's parallelism.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

targets=(obj ply stl off gltf md2 aff json points gzip rays)
usage() {
  echo "usage: scripts/fuzz.sh TARGET|all SECONDS, or scripts/fuzz.sh list (targets: ${targets[*]})" >&2
  exit 2
}
[[ ${1:-} == list ]] && { printf '%s\n' "${targets[@]}"; exit 0; }
[[ $# -eq 2 && $2 =~ ^[0-9]+$ ]] || usage
if [[ $1 == all ]]; then
  run=("${targets[@]}")
else
  name=${1#fuzz_}
  [[ " ${targets[*]} " == *" $name "* ]] || usage
  run=("$name")
fi
seconds=$2

dir=build-fuzz
launcher=()
if command -v ccache > /dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
mkdir -p "$dir"
nice cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER=clang++ -DSPLITRAY_FUZZ=ON -DSPLITRAY_BUILD_TESTS=OFF \
  -DSPLITRAY_BUILD_BENCH=OFF -DSPLITRAY_WITH_GL=OFF -DSPLITRAY_WITH_MPI=OFF \
  -DSPLITRAY_WITH_PYTHON=OFF "${launcher[@]}" > "$dir/configure.log" || {
  cat "$dir/configure.log" >&2
  exit 1
}
nice cmake --build "$dir" -j "${JOBS:-2}" --target "${run[@]/#/fuzz_}"

export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# Leaks inside Debian's assimp on malformed files are assimp's (each entry says why).
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/scripts/lsan.supp}
failed=()
for name in "${run[@]}"; do
  target=fuzz_$name
  binary=$dir/fuzz/$target
  findings=$dir/findings/$target
  mkdir -p "$dir/corpus/$target" "$findings"
  if [[ -d fuzz/regressions/$target ]] && [[ -n "$(ls -A "fuzz/regressions/$target")" ]]; then
    echo "== $target: replaying fuzz/regressions/$target"
    "$binary" -runs=1 fuzz/regressions/$target/* || { failed+=("$target (regressions)"); continue; }
  fi
  echo "== $target: fuzzing for $seconds s"
  options=(-max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=8192
           -print_final_stats=1 -artifact_prefix="$findings/")
  if [[ ${KEEP_GOING:-0} == 1 ]]; then
    options+=(-fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
  fi
  before=$(ls "$findings" | wc -l)
  status=0
  nice "$binary" "${options[@]}" "$dir/corpus/$target" "fuzz/corpus/$target" || status=$?
  after=$(ls "$findings" | wc -l)
  if [[ $status -ne 0 || $after -gt $before ]]; then
    failed+=("$target (findings in $findings)")
  fi
done
if [[ ${#failed[@]} -gt 0 ]]; then
  printf 'FAILED: %s\n' "${failed[@]}" >&2
  exit 1
fi
echo "== no findings"
