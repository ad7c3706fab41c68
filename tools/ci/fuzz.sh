#!/usr/bin/env bash
# Fuzzing job of continuous integration: builds, in the instrumented tree that it shares with the
# sanitizer job (build-san, or $1; configured by tools/ci/configure-sanitized.sh: clang, ASan +
# UBSan + coverage, -O1), the libFuzzer targets of tests/fuzz/ (the .lag reader, the scene reader,
# the checkpoint reader, the sweep-file reader, --set overrides of valid scenes and the trajectory
# CSV reader) and runs each for a fixed number of executions from the seed corpus. When the
# sanitizer job has built the tree already, only the six fuzz programs are compiled and linked.
# Fails on any crash, contract violation (abort), leak, UB report or input slower than -timeout
# (10 s; 60 s for the symbolic pipeline, where GiNaC under ASan takes up to a few seconds on a
# valid model of order 2 with gauss2 on an idle 2-core machine, a hang still fails).
# New interesting inputs are kept in BUILD_DIR/corpus_*; a failing input in BUILD_DIR/artifacts/.
#
# usage: tools/ci/fuzz.sh [BUILD_DIR]
# environment: JOBS (build parallelism, 2), LAG_RUNS (200000: the .lag reader alone),
#              LAG_PIPELINE_RUNS (5000: reader + symbolic pipeline, ~100x slower per input),
#              SCENE_RUNS (200000), MAX_SECONDS (per run, a guard on slow machines: 240),
#              CHECKPOINT_RUNS (500000), SWEEP_RUNS (500000), OVERRIDES_RUNS (500000),
#              TRAJECTORY_RUNS (200000), EXTRA_MAX_SECONDS (per run of these four: 55), MAX_LEN (4096)
set -euo pipefail
cd "$(dirname "$0")/../.."
build_dir="${1:-build-san}"
jobs="${JOBS:-2}"
lag_runs="${LAG_RUNS:-200000}"
lag_pipeline_runs="${LAG_PIPELINE_RUNS:-5000}"
scene_runs="${SCENE_RUNS:-200000}"
max_seconds="${MAX_SECONDS:-240}"
checkpoint_runs="${CHECKPOINT_RUNS:-500000}"
sweep_runs="${SWEEP_RUNS:-500000}"
overrides_runs="${OVERRIDES_RUNS:-500000}"
trajectory_runs="${TRAJECTORY_RUNS:-200000}"
extra_max_seconds="${EXTRA_MAX_SECONDS:-55}"
max_len="${MAX_LEN:-4096}"

export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# A one-time allocation of the CLN library at start-up (see the file) is not pardel's leak.
export LSAN_OPTIONS="suppressions=$PWD/tools/ci/lsan.supp:print_suppressions=0"

# The shared configuration (a no-op on a tree that it configured already).
bash tools/ci/configure-sanitized.sh "$build_dir"
cmake --build "$build_dir" -j "$jobs" --target fuzz_lag_parser fuzz_scene_parser fuzz_checkpoint_reader \
  fuzz_sweep_reader fuzz_scene_overrides fuzz_trajectory_reader

# Seed folders as configured by tests/fuzz/CMakeLists.txt (the corpora and the catalogues).
seeds() {
  sed -n "s/^$1:INTERNAL=//p" "$build_dir/CMakeCache.txt" | tr ';' ' '
}

failed=()
failed_logs=()
started="$build_dir/fuzz-started"
touch "$started"
run_fuzzer() {  # NAME RUNS DICT SEED_VARIABLE [MAX_SECONDS]
  local name=$1 runs=$2 dict=$3 seed_var=$4 seconds=${5:-$max_seconds}
  local corpus="$build_dir/corpus_${name#fuzz_}"
  local log="$build_dir/$name${PARDEL_FUZZ_PARSE_ONLY:+-reader}.log"
  mkdir -p "$corpus" "$build_dir/artifacts"
  echo "== $name: $runs executions (at most $seconds s), max_len $max_len${PARDEL_FUZZ_PARSE_ONLY:+, reader only}"
  # shellcheck disable=SC2046
  if ! "$build_dir/$name" -runs="$runs" -max_total_time="$seconds" -max_len="$max_len" -timeout="${TIMEOUT:-10}" \
      -rss_limit_mb=2048 -dict="$dict" -print_final_stats=1 \
      -artifact_prefix="$build_dir/artifacts/$name-" "$corpus" $(seeds "$seed_var") 2>&1 |
      tee "$log"; then
    echo "fuzz.sh: $name FAILED; the input is in $build_dir/artifacts/" >&2
    failed+=("$name${PARDEL_FUZZ_PARSE_ONLY:+ (reader only)}")
    failed_logs+=("$log")
  fi
}
PARDEL_FUZZ_PARSE_ONLY=1 run_fuzzer fuzz_lag_parser "$lag_runs" tests/fuzz/lag.dict PARDEL_FUZZ_LAG_SEEDS
TIMEOUT=60 run_fuzzer fuzz_lag_parser "$lag_pipeline_runs" tests/fuzz/lag.dict PARDEL_FUZZ_LAG_SEEDS
run_fuzzer fuzz_scene_parser "$scene_runs" tests/fuzz/scene.dict PARDEL_FUZZ_SCENE_SEEDS
run_fuzzer fuzz_checkpoint_reader "$checkpoint_runs" tests/fuzz/checkpoint.dict PARDEL_FUZZ_CHECKPOINT_SEEDS \
  "$extra_max_seconds"
run_fuzzer fuzz_sweep_reader "$sweep_runs" tests/fuzz/sweep.dict PARDEL_FUZZ_SWEEP_SEEDS "$extra_max_seconds"
run_fuzzer fuzz_scene_overrides "$overrides_runs" tests/fuzz/overrides.dict PARDEL_FUZZ_OVERRIDES_SEEDS \
  "$extra_max_seconds"
run_fuzzer fuzz_trajectory_reader "$trajectory_runs" tests/fuzz/trajectory.dict PARDEL_FUZZ_TRAJECTORY_SEEDS \
  "$extra_max_seconds"
# The summary comes last so that the tail of a long log names what failed, with each failing
# input in base64 (replay it with: base64 -d > input; BUILD_DIR/NAME input).
if ((${#failed[@]})); then
  for log in "${failed_logs[@]}"; do
    echo "fuzz.sh: the end of $log:" >&2
    tail -n 60 "$log" >&2
  done
  echo "fuzz.sh: FAILED: ${failed[*]}" >&2
  for artifact in "$build_dir"/artifacts/*; do
    [[ -f $artifact && $artifact -nt $started ]] || continue
    echo "fuzz.sh: $(basename "$artifact") ($(stat -c %s "$artifact") bytes, base64):" >&2
    head -c 4096 "$artifact" | base64 >&2
  done
  exit 1
fi
echo "fuzz.sh: every fuzz run clean"
