#!/usr/bin/env bash
# The prepared GPU script: on a machine with an NVIDIA GPU, runs the device test suite and the GPU
# benchmark (bench_device: pardel's device batches and sweeps against its CPU build on all cores;
# jax_peer.py: the seed's Jacobi-Newton in JAX on the same batches; Nsight Compute's view of the
# sweep kernel where `ncu` is there) and writes tables and logs to OUT (default out/gpu). The
# binaries come from a build with PARDEL_WITH_CUDA, here or copied from another machine (static
# CUDA runtime; docs/gpu.md):
#   tools/gpu/run.sh [BIN_DIR] [OUT]        (BIN_DIR default build)
# PYTHON names the interpreter that has JAX (default python3); BATCH the batch size (10000);
# BENCH_FLAGS more options of bench_device; PEER_BATCH, when set, a second, smaller batch size that
# bench_device solves (batches only) for the JAX peer, which then solves those batches instead;
# JAX_BATCHES the batches the peer solves (default "zermelo_N80 fuel_nav_N100"); JAX_LIMIT seconds
# for each JAX batch run (100); JAX_SWEEP=0 leaves out the peer's sweep at N = 10^7; PROFILE=0
# leaves out the profile; WORK the folder for the batches,
# the answers and the logs (default OUT/work; logs.tar.gz in OUT keeps the logs).
set -uo pipefail
bin=${1:-build}
out=${2:-out/gpu}
python=${PYTHON:-python3}
batch=${BATCH:-10000}
bench_flags=${BENCH_FLAGS:-}
peer_batch=${PEER_BATCH:-}
jax_batches=${JAX_BATCHES-zermelo_N80 fuel_nav_N100}
jax_limit=${JAX_LIMIT:-100}
work=${WORK:-$out/work}
mkdir -p "$out" "$work"
here=$(cd "$(dirname "$0")" && pwd)
status=0
started=$(date +%s)
{
  echo "== machine"
  nvidia-smi --query-gpu=name,memory.total,driver_version,clocks.max.sm --format=csv 2>&1
  nproc
  lscpu 2>/dev/null | grep -E "^(Model name|Socket|Core|Thread|NUMA node\(s\)|CPU\(s\))"
  echo "commit: ${PARDEL_COMMIT:-$(git -C "$here" rev-parse --short HEAD 2>/dev/null || echo unknown)}"
} | tee "$out/machine.txt"

echo "== device tests"
for t in test_cuda_device_kernels test_cuda_device_batch test_cuda_cyclic_reduction; do
  if ! timeout 150 "$bin/$t" --gtest_brief=1 >"$work/$t.log" 2>&1; then
    status=1
    echo "$t FAILED"
  fi
  tail -n 4 "$work/$t.log"
done
grep -h -B2 -A12 "Failure" "$work"/test_cuda_*.log | head -n 80
echo "(at $(( $(date +%s) - started )) s)"

echo "== pardel on the device and on the CPU"
if ! timeout 270 "$bin/bench_device" --out "$work" --batch "$batch" $bench_flags 2>&1 | tee "$out/bench_device.txt"; then
  status=1
fi
cp "$work/bench_device.json" "$out/" 2>/dev/null
echo "(at $(( $(date +%s) - started )) s)"

peer_work=$work
if [ -n "$peer_batch" ]; then
  echo "== pardel on the device, batches of $peer_batch for the JAX peer"
  peer_work=$work/peer
  mkdir -p "$peer_work"
  if ! timeout 120 "$bin/bench_device" --out "$peer_work" --batch "$peer_batch" --batches-only 1 --cpu-sample 16 2>&1 |
    tee "$out/bench_device_peer.txt"; then
    status=1
  fi
  cp "$peer_work/bench_device.json" "$out/bench_device_peer.json" 2>/dev/null
fi

if [ "${PROFILE:-1}" != 0 ]; then
  ncu=$(command -v ncu || ls /usr/local/cuda/bin/ncu 2>/dev/null || true)
  if [ -n "$ncu" ]; then
    echo "== Nsight Compute: the sweep kernel (sweeps 3 and 4 of a Zermelo batch of $batch, 0 and 1 of fuel navigation at N = 10^7)"
    mkdir -p "$work/profile"
    timeout 150 "$ncu" -k regex:sweep_kernel --launch-skip 3 --launch-count 4 --section SpeedOfLight --section Occupancy \
      --section LaunchStats --section MemoryWorkloadAnalysis --section WarpStateStats --section SchedulerStats \
      "$bin/bench_device" --out "$work/profile" --profile 1 --batch "$batch" >"$out/ncu.txt" 2>&1 || echo "ncu ended with $?"
    grep -E "sweep_kernel|Duration|Memory Throughput|DRAM Throughput|Compute \(SM\)|Achieved Occupancy|Theoretical Occupancy|Registers Per|Block Limit Registers|Warp Cycles Per Issued|Issued Warp Per Scheduler|No Eligible|Stall" "$out/ncu.txt" | head -n 100
  else
    echo "== no ncu: no profile"
  fi
  echo "(at $(( $(date +%s) - started )) s)"
fi

echo "== the JAX peer"
for name in $jax_batches; do
  if [ -f "$peer_work/$name.json" ]; then
    timeout "$jax_limit" "$python" "$here/jax_peer.py" --batch "$peer_work/$name.json" --json "$peer_work/jax_$name.json" \
      --solution "$peer_work/jax_$name.bin" 2>&1 | tail -n 3
    "$python" - "$peer_work" "$name" <<'PY' 2>&1
import json, sys
import numpy as np
work, name = sys.argv[1], sys.argv[2]
spec = json.load(open(f"{work}/{name}.json"))
shape = (spec["B"], spec["N"] + 1, spec["dim"])
mine = np.fromfile(f"{work}/{name}_pardel.bin").reshape(shape)
theirs = np.fromfile(f"{work}/jax_{name}.bin").reshape(shape)
peer = json.load(open(f"{work}/jax_{name}.json"))
print(f"{name}: B = {spec['B']}: JAX solve {peer['solve_seconds']:.3f} s (compile {peer['compile_seconds']:.1f} s), "
      f"{peer['converged']} of {spec['B']} converged; largest |pardel - JAX| over all nodes "
      f"{np.nanmax(np.abs(mine - theirs)):.2e}, median per problem "
      f"{np.nanmedian(np.nanmax(np.abs(mine - theirs), axis=(1, 2))):.2e}")
PY
  fi
done
if [ "${JAX_SWEEP:-1}" != 0 ]; then
  timeout 60 "$python" "$here/jax_peer.py" --sweep-only 10000000 --json "$work/jax_sweep.json" 2>&1 | tail -n 2
fi
cp "$work"/jax_*.json "$out/" 2>/dev/null
cp "$peer_work"/jax_*.json "$out/" 2>/dev/null
echo "(at $(( $(date +%s) - started )) s)"
tar -C "$work" -czf "$out/logs.tar.gz" --exclude='*.bin' . 2>/dev/null
exit $status
