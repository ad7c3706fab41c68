/**
 * @file cyclic_reduction_device.cuh
 * Block cyclic reduction on the device: cyclic_reduction.hpp's row functions, one thread per
 * row, one launch per level and step, over storage in device memory. The host decides nothing
 * between launches: a pivot that is not positive definite sets a flag in device memory, which
 * the host reads once after the whole solve, so one solve costs one synchronization (the step
 * logic of a Newton iteration on the host reads it there).
 */
#ifndef PARDEL_CUDA_CYCLIC_REDUCTION_DEVICE_CUH
#define PARDEL_CUDA_CYCLIC_REDUCTION_DEVICE_CUH

#include <cuda_runtime.h>

#include "cyclic_reduction.hpp"

namespace pardel::cyclic_reduction {
namespace device {

constexpr int kThreads = 128;

inline unsigned blocks(long rows) { return static_cast<unsigned>((rows + kThreads - 1) / kThreads); }

template <int D>
__global__ void eliminate_rows(Level A, int d, int* failed) {
  const long j = 2 * (static_cast<long>(blockIdx.x) * blockDim.x + threadIdx.x);
  if (j < A.n && !eliminate<D>(A, j, d)) atomicExch(failed, 1);
}

template <int D>
__global__ void reduce_rows(Level A, Level B, int d) {
  const long m = static_cast<long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (m < B.n) reduce<D>(A, B, m, d);
}

template <int D>
__global__ void solve_top_row(Level top, int d, int* failed) {
  if (blockIdx.x == 0 && threadIdx.x == 0 && !solve_top<D>(top, d)) atomicExch(failed, 1);
}

template <int D>
__global__ void substitute_rows(Level A, Level B, int d) {
  const long r = static_cast<long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (r < A.n) substitute<D>(A, B, r, d);
}

}  // namespace device

/**
 * The device path of solve_on_host: `base` in device memory (values(n, d) doubles, level 0's S,
 * U and b filled), `failed` one int of device memory; level 0's x the solution. Launches on
 * `stream` and waits for it once; *positive_definite false where a pivot was not (x then
 * meaningless). A CUDA error is returned as such.
 */
template <int D>
cudaError_t solve_on_device(double* base, long n, int d, int* failed, bool* positive_definite,
                            cudaStream_t stream = nullptr) {
  *positive_definite = true;
  if (n <= 0) return cudaSuccess;
  cudaError_t status = cudaMemsetAsync(failed, 0, sizeof(int), stream);
  if (status != cudaSuccess) return status;
  const int levels = level_count(n);
  for (int l = 0; l + 1 < levels; ++l) {
    const Level A = level(base, n, d, l), B = level(base, n, d, l + 1);
    device::eliminate_rows<D><<<device::blocks((A.n + 1) / 2), device::kThreads, 0, stream>>>(A, d, failed);
    device::reduce_rows<D><<<device::blocks(B.n), device::kThreads, 0, stream>>>(A, B, d);
  }
  device::solve_top_row<D><<<1, 1, 0, stream>>>(level(base, n, d, levels - 1), d, failed);
  for (int l = levels - 1; l-- > 0;) {
    const Level A = level(base, n, d, l), B = level(base, n, d, l + 1);
    device::substitute_rows<D><<<device::blocks(A.n), device::kThreads, 0, stream>>>(A, B, d);
  }
  int flag = 0;
  status = cudaMemcpyAsync(&flag, failed, sizeof(int), cudaMemcpyDeviceToHost, stream);
  if (status == cudaSuccess) status = cudaStreamSynchronize(stream);
  if (status == cudaSuccess) status = cudaGetLastError();
  *positive_definite = flag == 0;
  return status;
}

}  // namespace pardel::cyclic_reduction

#endif  // PARDEL_CUDA_CYCLIC_REDUCTION_DEVICE_CUH
