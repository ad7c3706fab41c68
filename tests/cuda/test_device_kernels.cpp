// The generated kernels compiled from the same source as CUDA (PARDEL_HD): evaluated over a
// trajectory by one per-interval function in a host loop, their first and second derivatives agree
// with central differences of the action and gradient they return (relative to the interval's
// largest value of each kind); evaluated one interval per
// device thread, they agree with the host loop to 1e-12 (relative to the interval's largest value).
// The device part skips, saying why, on a machine without a CUDA device.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "device_kernels.hpp"

namespace {

using pardel_cuda_check::device_model;
using pardel_cuda_check::evaluate_on_device;
using pardel_cuda_check::evaluate_on_host;
using pardel_cuda_check::values_per_interval;

struct Case {
  std::string model;
  int N;
  std::vector<double> q, t, p;
  int m = 0;
};

/** A smooth trajectory no scene uses: q_k[i] = 0.4 sin(1.7 s + 0.9 i) + 0.2 i s with s = k/N,
 *  on the times 0.3 + 2 s + 0.1 s². */
Case make_case(const std::string& model, int N) {
  Case c{model, N, {}, {}, {}};
  const pardel_model* m = device_model(model);
  if (!m) return c;
  c.m = m->dim;
  for (int k = 0; k <= N; ++k) {
    const double s = static_cast<double>(k) / N;
    c.t.push_back(0.3 + 2 * s + 0.1 * s * s);
    for (int i = 0; i < c.m; ++i) c.q.push_back(0.4 * std::sin(1.7 * s + 0.9 * i) + 0.2 * i * s);
  }
  for (int j = 0; j < m->nparams; ++j) c.p.push_back(m->param_defaults[j] * 1.1);
  return c;
}

class DeviceKernels : public ::testing::TestWithParam<std::string> {};

TEST_P(DeviceKernels, HostLoopDerivativesMatchCentralDifferences) {
  const Case c = make_case(GetParam(), 8);
  ASSERT_GT(c.m, 0) << "model not compiled for the check";
  const int m = c.m, V = values_per_interval(m);
  const std::vector<double> base = evaluate_on_host(c.model, c.N, c.q, c.t, c.p);
  ASSERT_EQ(base.size(), static_cast<std::size_t>(c.N) * V);
  // Perturbing node j moves D2 of interval j-1 and D1 of interval j; compare interval j's values,
  // each difference relative to the largest value of its kind on the interval (the differences'
  // round-off scales with those: order-4 kernels carry terms in h^-7).
  const double eps = 1e-5;
  double worst_first = 0, worst_second = 0;
  for (int j = 0; j < c.N; ++j) {
    for (int i = 0; i < 2 * m; ++i) {  // i < m: q0 component of interval j; else q1 component
      const int node = i < m ? j : j + 1, comp = i % m;
      std::vector<double> plus = c.q, minus = c.q;
      plus[static_cast<std::size_t>(node) * m + comp] += eps;
      minus[static_cast<std::size_t>(node) * m + comp] -= eps;
      const std::vector<double> vp = evaluate_on_host(c.model, c.N, plus, c.t, c.p);
      const std::vector<double> vm = evaluate_on_host(c.model, c.N, minus, c.t, c.p);
      const double* b = base.data() + static_cast<std::size_t>(j) * V;
      const double* P = vp.data() + static_cast<std::size_t>(j) * V;
      const double* M = vm.data() + static_cast<std::size_t>(j) * V;
      double first_scale = 1, second_scale = 1;
      for (int v = 0; v < 1 + 2 * m; ++v) first_scale = std::max(first_scale, std::fabs(b[v]));
      for (int v = 1; v < V; ++v) second_scale = std::max(second_scale, std::fabs(b[v]));
      // dLd/dx_i against D1 (i < m) or D2.
      worst_first = std::max(worst_first, std::fabs((P[0] - M[0]) / (2 * eps) - b[1 + i]) / first_scale);
      // d(D1, D2)/dx_i against the Hessian blocks: row r of [D1; D2], column i of [[D11 D12]; [D21 D22]].
      for (int r = 0; r < 2 * m; ++r) {
        double exact;
        if (r < m && i < m) exact = b[1 + 2 * m + r * m + i];                    // D11
        else if (r < m) exact = b[1 + 2 * m + m * m + r * m + (i - m)];          // D12
        else if (i < m) exact = b[1 + 2 * m + m * m + i * m + (r - m)];          // D21 = D12^T
        else exact = b[1 + 2 * m + 2 * m * m + (r - m) * m + (i - m)];           // D22
        worst_second = std::max(worst_second, std::fabs((P[1 + r] - M[1 + r]) / (2 * eps) - exact) / second_scale);
      }
    }
  }
  EXPECT_LT(worst_first, 1e-6) << c.model;
  EXPECT_LT(worst_second, 1e-6) << c.model;
}

TEST_P(DeviceKernels, DeviceMatchesTheHostLoop) {
  const Case c = make_case(GetParam(), 1000);
  ASSERT_GT(c.m, 0) << "model not compiled for the check";
  const std::vector<double> host = evaluate_on_host(c.model, c.N, c.q, c.t, c.p);
  std::vector<double> device;
  std::string why;
  if (!evaluate_on_device(c.model, c.N, c.q, c.t, c.p, device, why)) GTEST_SKIP() << why;
  ASSERT_EQ(device.size(), host.size());
  // Relative to the interval's largest value: the device contracts a*b+c into fused multiply-adds,
  // so values that are sums of cancelling terms differ in their last bits of those terms.
  const std::size_t V = static_cast<std::size_t>(values_per_interval(c.m));
  double worst = 0;
  for (std::size_t k = 0; k < host.size() / V; ++k) {
    double scale = 1;
    for (std::size_t v = 0; v < V; ++v) scale = std::max(scale, std::fabs(host[k * V + v]));
    for (std::size_t v = 0; v < V; ++v) {
      ASSERT_TRUE(std::isfinite(device[k * V + v])) << "interval " << k << ", value " << v;
      worst = std::max(worst, std::fabs(device[k * V + v] - host[k * V + v]) / scale);
    }
  }
  EXPECT_LT(worst, 1e-12) << c.model;
}

INSTANTIATE_TEST_SUITE_P(BundledModels, DeviceKernels,
                         ::testing::Values("bratu", "fuel_nav", "min_snap", "zermelo_tv"));

}  // namespace
