// Host-callable entry points of the device-kernel check (device_kernels.cu, compiled as CUDA): the
// bundled models' generated kernels, compiled from the same source for the host and the device,
// evaluated over every interval of a trajectory by one per-interval function, either in a host loop
// or one interval per device thread.
#pragma once

#include <string>
#include <vector>

#include "pardel/kernel_abi.h"

namespace pardel_cuda_check {

/** The models this check compiles for the device, by name; nullptr for another name. */
const pardel_model* device_model(const std::string& name);

/** Values of one interval's full kernel: Ld, D1, D2, D11, D12, D22 (1 + 2m + 3m² values). */
int values_per_interval(int m);

/** Evaluates the full kernel of `model`'s first discretization on every interval of the
 *  trajectory (q: (N+1)·m values, t: N+1 node times, p: the params) through the per-interval
 *  function, in a host loop. */
std::vector<double> evaluate_on_host(const std::string& model, int N, const std::vector<double>& q,
                                     const std::vector<double>& t, const std::vector<double>& p);

/** The same, one interval per device thread. Returns false (with `why`) when no device can run
 *  it: no CUDA driver, no device, or a failed CUDA call. */
bool evaluate_on_device(const std::string& model, int N, const std::vector<double>& q, const std::vector<double>& t,
                        const std::vector<double>& p, std::vector<double>& out, std::string& why);

}  // namespace pardel_cuda_check
