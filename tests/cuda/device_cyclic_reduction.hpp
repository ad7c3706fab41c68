// The device half of the cyclic-reduction check (device_cyclic_reduction.cu, compiled as CUDA):
// one solve of a block-tridiagonal system on the device, for the host test to compare with the
// host path.
#ifndef PARDEL_TESTS_CUDA_DEVICE_CYCLIC_REDUCTION_HPP
#define PARDEL_TESTS_CUDA_DEVICE_CYCLIC_REDUCTION_HPP

#include <string>
#include <vector>

namespace pardel_cuda_check {

/**
 * Solves the system whose level-0 storage (cyclic_reduction::values(n, d) doubles, S, U and b
 * filled) is `storage` on the device, block size d (2 and 4 compiled for it, others at run time);
 * x: level 0's solution. False with `why` where no device can run it (no device, a CUDA error);
 * *positive_definite as cyclic_reduction::solve_on_device says.
 */
bool cyclic_reduction_on_device(const std::vector<double>& storage, long n, int d, std::vector<double>& x,
                                bool* positive_definite, std::string& why);

}  // namespace pardel_cuda_check

#endif  // PARDEL_TESTS_CUDA_DEVICE_CYCLIC_REDUCTION_HPP
