#!/usr/bin/env bash
# Checks README's first command's configuration (-DPARDEL_CLI_ONLY=ON) without building it: the
# `pardel` target compiles no CUDA, MPI, test, benchmark or Python source and does not run the
# generator over the bundled models, but builds the generator that the model loader runs on .lag
# files; the folder keeps no cached MPI or CUDA switch of its own, so that -DPARDEL_CLI_ONLY=OFF on
# the same folder configures the full build again, with the switches of a default configuration
# on this machine.
# Usage: cli_only.sh SOURCE_DIR WORK_DIR
set -euo pipefail
src=$1 work=$2
rm -rf "$work" "$work.default"
fail() { echo "cli_only.sh: $*" >&2; exit 1; }

cmake -S "$src" -B "$work" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPARDEL_CLI_ONLY=ON > "$work.log" 2>&1 ||
  { cat "$work.log"; fail "configure with -DPARDEL_CLI_ONLY=ON failed"; }
commands=$(ninja -C "$work" -t commands pardel)
[ -n "$commands" ] || fail "the target pardel has no build commands"
grep -q -- "src/newton.cpp" <<<"$commands" || fail "the runtime is not part of the target pardel"
grep -q -- "generated/fuel_nav.cpp" <<<"$commands" || fail "the committed fuel_nav kernel is not compiled"
grep -q -- "codegen/pardel_gen.cpp" <<<"$commands" ||
  fail "pardel-gen, which the model loader runs on a scene's own .lag file, is not built"
unwanted() {  # grep's mode (-E or -F), then the pattern
  if grep -q "$1" -- "$2" <<<"$commands"; then
    grep "$1" -- "$2" <<<"$commands" | head -3 >&2
    fail "the target pardel builds or runs '$2' under -DPARDEL_CLI_ONLY=ON"
  fi
}
unwanted -E 'nvcc|\.cu( |$)'
unwanted -E 'pardel-gen .*\.lag'
for source in src/mpi/decomposition.cpp python/src/ "-c $src/tests/" "-c $src/tools/benchmarks/"; do
  unwanted -F "$source"
done
for key in PARDEL_WITH_MPI PARDEL_WITH_CUDA PARDEL_REGENERATE; do
  if grep -q "^$key:" "$work/CMakeCache.txt"; then fail "-DPARDEL_CLI_ONLY=ON cached $key"; fi
done

# The same folder back to a full configuration: its switches are those of a folder configured
# without PARDEL_CLI_ONLY (what this machine detects: MPI, CUDA, GiNaC, pybind11).
cmake -S "$src" -B "$work" -DPARDEL_CLI_ONLY=OFF > "$work.log" 2>&1 ||
  { cat "$work.log"; fail "configure with -DPARDEL_CLI_ONLY=OFF failed"; }
cmake -S "$src" -B "$work.default" -G Ninja -DCMAKE_BUILD_TYPE=Release > "$work.log" 2>&1 ||
  { cat "$work.log"; fail "the default configuration failed"; }
for key in PARDEL_WITH_MPI PARDEL_WITH_CUDA PARDEL_REGENERATE PARDEL_BUILD_TESTS PARDEL_BUILD_PYTHON; do
  want=$(grep "^$key:" "$work.default/CMakeCache.txt" | cut -d= -f2)
  got=$(grep "^$key:" "$work/CMakeCache.txt" | cut -d= -f2)
  [ "$want" = "$got" ] || fail "$key is '$got' after -DPARDEL_CLI_ONLY=OFF, '$want' in a default configuration"
done
targets=$(ninja -C "$work" -t targets all)
grep -q "^test_cli_pardel:" <<<"$targets" || fail "no test targets after -DPARDEL_CLI_ONLY=OFF"
rm -rf "$work" "$work.default" "$work.log"
echo "cli_only.sh: ok"
