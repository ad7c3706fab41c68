// Block cyclic reduction on the device (runtime/cuda/cyclic_reduction_device.cuh) against its host
// path (runtime/src/cyclic_reduction.hpp, itself checked against dense solves in
// tests/runtime/test_cyclic_reduction.cpp): random symmetric positive definite block-tridiagonal
// systems of 1 to 2^20 + 3 rows and block sizes 2, 4 and 3 (a size known at run time), solutions
// agreeing to 1e-12; an indefinite system refused by both. Skipped, saying why, on a machine
// without a CUDA device.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "cyclic_reduction.hpp"
#include "device_cyclic_reduction.hpp"

namespace {

namespace cr = pardel::cyclic_reduction;

/** Storage for n rows of size d with level 0 filled: random symmetric diagonal blocks plus
 *  `boost` I, random couplings, a random right-hand side. */
std::vector<double> random_storage(long n, int d, double boost, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> store(static_cast<std::size_t>(cr::values(n, d)), 0.0);
  const cr::Level L0 = cr::level(store.data(), n, d, 0);
  for (long i = 0; i < n; ++i) {
    double* S = L0.S + i * d * d;
    for (int a = 0; a < d; ++a)
      for (int c = 0; c <= a; ++c) S[a * d + c] = S[c * d + a] = u(rng) + (a == c ? boost : 0.0);
    if (i + 1 < n)
      for (int k = 0; k < d * d; ++k) L0.U[i * d * d + k] = u(rng);
    for (int a = 0; a < d; ++a) L0.b[i * d + a] = u(rng);
  }
  return store;
}

bool host_solve(std::vector<double> store, long n, int d, std::vector<double>& x) {
  const bool ok = d == 2 ? cr::solve_on_host<2>(store.data(), n, d, 1, 1 << 30)
                  : d == 4 ? cr::solve_on_host<4>(store.data(), n, d, 1, 1 << 30)
                           : cr::solve_on_host<-1>(store.data(), n, d, 1, 1 << 30);
  const cr::Level L0 = cr::level(store.data(), n, d, 0);
  x.assign(L0.x, L0.x + n * d);
  return ok;
}

TEST(DeviceCyclicReduction, SolvesAsTheHostPath) {
  for (int d : {2, 3, 4}) {
    for (long n : {1L, 2L, 3L, 17L, 1000L, (1L << 20) + 3}) {
      const std::vector<double> store = random_storage(n, d, 3.0 * d, 1000u * d + static_cast<unsigned>(n % 997));
      std::vector<double> host, device;
      ASSERT_TRUE(host_solve(store, n, d, host));
      bool definite = false;
      std::string why;
      if (!pardel_cuda_check::cyclic_reduction_on_device(store, n, d, device, &definite, why)) GTEST_SKIP() << why;
      ASSERT_TRUE(definite) << "d = " << d << ", n = " << n;
      double worst = 0, size = 0;
      for (std::size_t i = 0; i < host.size(); ++i) {
        worst = std::max(worst, std::fabs(device[i] - host[i]));
        size = std::max(size, std::fabs(host[i]));
      }
      EXPECT_LE(worst, 1e-12 * size) << "d = " << d << ", n = " << n;
    }
  }
}

TEST(DeviceCyclicReduction, AnIndefiniteSystemIsRefusedAsOnTheHost) {
  const long n = 4097;
  const int d = 2;
  std::vector<double> store = random_storage(n, d, 3.0 * d, 5u);
  const cr::Level L0 = cr::level(store.data(), n, d, 0);
  L0.S[(n / 3) * d * d] = -50;  // one diagonal entry far below its row's couplings: indefinite
  std::vector<double> host, device;
  EXPECT_FALSE(host_solve(store, n, d, host));
  bool definite = true;
  std::string why;
  if (!pardel_cuda_check::cyclic_reduction_on_device(store, n, d, device, &definite, why)) GTEST_SKIP() << why;
  EXPECT_FALSE(definite);
}

}  // namespace
