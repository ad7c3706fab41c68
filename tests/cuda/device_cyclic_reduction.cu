// The device half of the cyclic-reduction check: runtime/cuda/cyclic_reduction_device.cuh on a
// system copied to the device, its solution copied back.
#include "device_cyclic_reduction.hpp"

#include <cuda_runtime.h>

#include "cyclic_reduction_device.cuh"

namespace pardel_cuda_check {

bool cyclic_reduction_on_device(const std::vector<double>& storage, long n, int d, std::vector<double>& x,
                                bool* positive_definite, std::string& why) {
  int devices = 0;
  cudaError_t status = cudaGetDeviceCount(&devices);
  if (status != cudaSuccess || devices == 0) {
    why = std::string("no CUDA device: ") + (status != cudaSuccess ? cudaGetErrorString(status) : "none found");
    return false;
  }
  double* base = nullptr;
  int* failed = nullptr;
  const std::size_t bytes = storage.size() * sizeof(double);
  status = cudaMalloc(&base, bytes);
  if (status == cudaSuccess) status = cudaMalloc(&failed, sizeof(int));
  if (status == cudaSuccess) status = cudaMemcpy(base, storage.data(), bytes, cudaMemcpyHostToDevice);
  if (status == cudaSuccess) {
    namespace cr = pardel::cyclic_reduction;
    status = d == 2   ? cr::solve_on_device<2>(base, n, d, failed, positive_definite)
             : d == 4 ? cr::solve_on_device<4>(base, n, d, failed, positive_definite)
                      : cr::solve_on_device<-1>(base, n, d, failed, positive_definite);
  }
  if (status == cudaSuccess) {
    const pardel::cyclic_reduction::Level L0 = pardel::cyclic_reduction::level(base, n, d, 0);
    x.resize(static_cast<std::size_t>(n) * d);
    status = cudaMemcpy(x.data(), L0.x, x.size() * sizeof(double), cudaMemcpyDeviceToHost);
  }
  cudaFree(base);
  cudaFree(failed);
  if (status != cudaSuccess) {
    why = std::string("CUDA error: ") + cudaGetErrorString(status);
    return false;
  }
  return true;
}

}  // namespace pardel_cuda_check
