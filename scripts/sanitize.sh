#!/usr/bin/env bash
# The test suite under sanitizers, each in its own build folder (README "Reliability:
# sanitizers and fuzzing"):
#   scripts/sanitize.sh address   ASan + UBSan over the whole ctest suite (build-asan/)
#   scripts/sanitize.sh thread    TSan over the parallel builders and renderers (build-tsan/):
#                                 the tests that compare one thread with several, batched with
#                                 single-ray queries, and the renderers' tests
# Extra arguments go to ctest (e.g. -R kd_test). JOBS (default 2) sets the build's and
# ctest's parallelism. A sanitizer report fails the test that caused it; each test's sanitizer
# options (suppression files, stack traces) come from cmake/sanitizers.cmake.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

mode=${1:-}
[[ $# -gt 0 ]] && shift
jobs=${JOBS:-2}
launcher=()
if command -v ccache > /dev/null; then
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi

case "$mode" in
  address)
    dir=build-asan
    nice cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
      "-DSPLITRAY_SANITIZE=address;undefined" "${launcher[@]}"
    nice cmake --build "$dir" -j "$jobs"
    ctest --test-dir "$dir" --output-on-failure -j "$jobs" --timeout 3000 "$@"
    ;;
  thread)
    dir=build-tsan
    tests=(kd_builders_test kd_test kd_coherent_test animated_accel_test bih_test bvh_test knn_test
           ray_sets_test render_test hybrid_test)
    nice cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSPLITRAY_SANITIZE=thread \
      -DSPLITRAY_WITH_PYTHON=OFF -DSPLITRAY_WITH_MPI=OFF "${launcher[@]}"
    nice cmake --build "$dir" -j "$jobs" --target "${tests[@]}"
    # Within those executables: the tests that run several threads against one (the trees and
    # answers must not depend on the thread count), batched against single queries, and the
    # renderers (TBB-parallel tiles; the hybrid renderer's CPU and GPU halves), and the
    # coherent kd rebuild and animated structures (parallel subtree tasks, every frame).
    regex="^($(IFS='|'; echo "${tests[*]}"))\$"
    GTEST_FILTER=${GTEST_FILTER:-'*Thread*:*Batch*:Whitted*:Hybrid*:Render*:KdCoherent.EqualsBrute*:AnimatedAccel.Every*'} \
      ctest --test-dir "$dir" --output-on-failure -j "$jobs" --timeout 3000 -R "$regex" "$@"
    ;;
  *)
    echo "usage: scripts/sanitize.sh address|thread [ctest arguments]" >&2
    exit 2
    ;;
esac
