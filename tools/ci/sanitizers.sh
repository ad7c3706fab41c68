#!/usr/bin/env bash
# Sanitizer job of continuous integration: configures a second build (build-asan, or $1) with
# AddressSanitizer + UndefinedBehaviorSanitizer (UB is fatal), builds everything, and runs the
# whole ctest suite under ASan/UBSan with leak detection. Exits non-zero on any build error,
# failing test or sanitizer report.
#
# Tests labelled `sanitizer_slow` are left out of this run only (they run in the normal build);
# see docs/reliability.md for which tests carry the label and why.
#
# usage: tools/ci/sanitizers.sh [BUILD_DIR]      (environment: JOBS, default 2)
set -euo pipefail
cd "$(dirname "$0")/../.."
build_dir="${1:-build-asan}"
jobs="${JOBS:-2}"

san_flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"

# The same options for the build: pardel-gen and the test discovery run instrumented binaries.
# Leaks stay fatal everywhere; UBSan prints a stack and stops at the first report.
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# A one-time allocation of the CLN library at start-up (see the file) is not pardel's leak.
export LSAN_OPTIONS="suppressions=$PWD/tools/ci/lsan.supp:print_suppressions=0"
# Models compiled at run time by the tests go to a cache inside the build folder.
case "$build_dir" in
  /*) export PARDEL_CACHE_DIR="$build_dir/model-cache" ;;
  *) export PARDEL_CACHE_DIR="$PWD/$build_dir/model-cache" ;;
esac

start=$(date +%s)
cmake -S . -B "$build_dir" -G Ninja \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_FLAGS="$san_flags" \
  -DCMAKE_CXX_FLAGS="$san_flags" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DPARDEL_BUILD_BENCHMARKS=OFF
cmake --build "$build_dir" -j "$jobs"
built=$(date +%s)

ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" --label-exclude sanitizer_slow \
  --timeout 900
done_at=$(date +%s)
echo "sanitizers.sh: build $((built - start)) s, tests $((done_at - built)) s, all passed under ASan/UBSan"
