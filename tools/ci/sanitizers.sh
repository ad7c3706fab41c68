#!/usr/bin/env bash
# Sanitizer job of continuous integration: a reduced build (build-asan, or $1) with
# AddressSanitizer + UndefinedBehaviorSanitizer (UB fatal, leaks fatal) at -O1 of what handles
# untrusted input and memory: the .lag reader (fuzz_lag_parser_replay and the .lag catalogue
# test), the scene reader and the command line (fuzz_scene_parser_replay, test_cli_*, pardel),
# and the runtime solvers (runtime_test_*, checkpoint/resume, non-finite models). Kernels come
# from the committed generated/ (PARDEL_REGENERATE=OFF); benchmarks and MPI are off. Only the
# ctest tests of the built targets run. Exits non-zero on any build error, failing test or
# sanitizer report.
#
# What is left out, and why: the code generator's other tests (test_codegen_* except the .lag
# parser: they compile generated C++ with the system compiler, minutes each under ASan), the
# hostile-model test (the same), the memory-estimate test (it measures resident memory and sets
# RLIMIT_AS, which ASan's shadow memory defeats), the sweep and model-loader tests, and tests
# labelled `sanitizer_slow`. docs/reliability.md lists the measured build and test times.
#
# usage: tools/ci/sanitizers.sh [BUILD_DIR]      (environment: JOBS, default 2)
set -euo pipefail
cd "$(dirname "$0")/../.."
build_dir="${1:-build-asan}"
jobs="${JOBS:-2}"

# PARDEL_CHECK_INVARIANTS: the runtime's internal invariants (runtime/src/invariant.hpp) are checked.
san_flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined -DPARDEL_CHECK_INVARIANTS"

# The same options for the build: test discovery runs the instrumented binaries.
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# A one-time allocation of the CLN library at start-up (see the file) is not pardel's leak.
export LSAN_OPTIONS="suppressions=$PWD/tools/ci/lsan.supp:print_suppressions=0"
# Models compiled at run time by the tests go to a cache inside the build folder.
case "$build_dir" in
  /*) export PARDEL_CACHE_DIR="$build_dir/model-cache" ;;
  *) export PARDEL_CACHE_DIR="$PWD/$build_dir/model-cache" ;;
esac

targets=(
  pardel
  fuzz_lag_parser_replay fuzz_scene_parser_replay test_codegen_lag_parser
  test_cli_scene test_cli_pardel test_cli_trajectory_io test_cli_outputs test_cli_progress test_cli_exit_codes
  runtime_test_api runtime_test_block_tridiagonal runtime_test_certificate runtime_test_clock
  runtime_test_hybrid runtime_test_jacobi runtime_test_jacobi_newton runtime_test_knots
  runtime_test_newton runtime_test_refinement runtime_test_stationary runtime_test_trajectory
  runtime_test_component_scale runtime_test_batch_sweep
  test_reliability_checkpoint_resume test_reliability_checkpoint_cli test_reliability_nonfinite_models
)

start=$(date +%s)
cmake -S . -B "$build_dir" -G Ninja \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g -DNDEBUG" \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g -DNDEBUG" \
  -DCMAKE_C_FLAGS="$san_flags" \
  -DCMAKE_CXX_FLAGS="$san_flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DPARDEL_REGENERATE=ON \
  -DPARDEL_BUILD_BENCHMARKS=OFF \
  -DPARDEL_WITH_MPI=OFF \
  -DPARDEL_WITH_CUDA=OFF
# Targets that this configuration does not define (e.g. without GiNaC) are skipped.
available=()
for t in "${targets[@]}"; do
  if ninja -C "$build_dir" -t query "$t" >/dev/null 2>&1; then available+=("$t"); else echo "sanitizers.sh: no target $t here"; fi
done
cmake --build "$build_dir" -j "$jobs" --target "${available[@]}"
built=$(date +%s)

# The ctest tests whose program was built (ctest would report the others as not built); the Python
# module's tests, the package test and the HTML reference (labels python, package, docs) need
# targets this job does not build, and the configuration test (label configure) runs no compiled
# code of pardel's.
tests=$(ctest --test-dir "$build_dir" --show-only=json-v1 | /usr/bin/python3 -c '
import json, os, sys
info = json.load(sys.stdin)
picked = [str(i + 1) for i, t in enumerate(info["tests"])
          if t.get("command") and os.path.exists(t["command"][0])
          and not any(p["name"] == "LABELS" and {"sanitizer_slow", "python", "package", "docs", "configure"} & set(p["value"])
                      for p in t.get("properties", []))]
print(",".join(picked))')
if [ -z "$tests" ]; then
  echo "sanitizers.sh: no tests found" >&2
  exit 1
fi
ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" --timeout 900 -I "0,0,0,$tests"
done_at=$(date +%s)
echo "sanitizers.sh: build $((built - start)) s, tests $((done_at - built)) s, $(tr ',' '\n' <<<"$tests" | wc -l) tests selected (disabled ones are not run), no failure under ASan/UBSan"
