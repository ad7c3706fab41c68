/**
 * @file bench_sweep.cpp
 * pardel-bench-sweep (Google Benchmark): the cost of one Jacobi-Newton sweep of the seed's
 * fuel-optimal example against N and threads, next to the cost of evaluating the sweep kernel
 * alone on every interval (the limit a sweep can reach), and the time to solution of Newton
 * (nested iteration). Arguments of each benchmark: N, threads. Counters: node updates per second.
 */
#include <benchmark/benchmark.h>

#include <chrono>
#include <vector>

#include "pardel/pardel.hpp"

namespace {

pardel::Problem fuel(int N) {
  pardel::Problem p;
  p.model = pardel::find_model("fuel_nav");
  if (p.model) p.discretization = pardel::find_discretization(*p.model, "trapezoid");
  p.T = 30;
  p.N = N;
  p.q0 = {0, 0};
  p.qN = {6, 5};
  return p;
}

/** The sweep kernel on every interval, in parallel: D1, D2, D11, D22 of N intervals. */
void BM_SweepKernelsOnly(benchmark::State& state) {
  const int N = static_cast<int>(state.range(0)), threads = static_cast<int>(state.range(1));
  const pardel::Problem p = fuel(N);
  if (!p.model) return state.SkipWithError("fuel_nav is not bundled");
  const pardel::Trajectory tr = pardel::linear_guess(p);
  const int d = p.model->dim;
  const std::size_t dd = static_cast<std::size_t>(d) * d;
  std::vector<double> D1(static_cast<std::size_t>(N) * d), D2(D1.size()), D11(N * dd), D22(N * dd);
  const double h = p.T / N;
  const pardel_sweep_kernel kern = p.discretization->sweep;
  const double* q = tr.q.data();
  for (auto _ : state) {
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int k = 0; k < N; ++k) {
      const std::size_t kk = static_cast<std::size_t>(k);
      kern(h, k * h, (k + 1) * h, q + kk * d, q + (kk + 1) * d, nullptr, &D1[kk * d], &D2[kk * d], &D11[kk * dd],
           &D22[kk * dd]);
    }
    benchmark::DoNotOptimize(D1.data());
    benchmark::ClobberMemory();
  }
  state.counters["node_updates_per_s"] =
      benchmark::Counter(static_cast<double>(N - 1) * state.iterations(), benchmark::Counter::kIsRate);
}

/** Wall time of `iterations` Jacobi-Newton sweeps from the straight line (setup included). */
double sweeps_seconds(const pardel::Problem& p, int threads, long iterations) {
  pardel::Options o;
  o.method = pardel::Method::jacobi_newton;
  o.threads = threads;
  o.max_iterations = iterations;
  o.history_every = 1L << 40;  // record only the start: no action evaluations in between
  pardel::Trajectory tr = pardel::linear_guess(p);
  const auto t0 = std::chrono::steady_clock::now();
  const pardel::Summary s = pardel::solve(p, o, tr);
  benchmark::DoNotOptimize(s.residual);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/** One Jacobi-Newton sweep: the difference of two solves with different sweep counts, which
 *  cancels the setup and the final action evaluation. */
void BM_JacobiNewtonSweep(benchmark::State& state) {
  const int N = static_cast<int>(state.range(0)), threads = static_cast<int>(state.range(1));
  const pardel::Problem p = fuel(N);
  if (!p.model) return state.SkipWithError("fuel_nav is not bundled");
  const long few = 2, many = N >= 1000000 ? 12 : 42;
  for (auto _ : state) {
    const double a = sweeps_seconds(p, threads, few);
    const double b = sweeps_seconds(p, threads, many);
    state.SetIterationTime(std::max(1e-12, (b - a) / static_cast<double>(many - few)));
  }
  state.counters["node_updates_per_s"] =
      benchmark::Counter(static_cast<double>(N - 1), benchmark::Counter::kIsIterationInvariantRate);
}

/** Time to solution (residual 1e-10) from the straight line; Newton by nested iteration from
 *  N = 200 (doubling N), as docs/solvers.md recommends for large N. */
void solve_to_tol(benchmark::State& state, pardel::Method method) {
  const int N = static_cast<int>(state.range(0)), threads = static_cast<int>(state.range(1));
  const pardel::Problem p = fuel(N);
  if (!p.model) return state.SkipWithError("fuel_nav is not bundled");
  pardel::Options o;
  o.method = method;
  o.threads = threads;
  o.tol = 1e-10;
  o.max_iterations = 10000;
  o.history_every = 1L << 40;
  if (method == pardel::Method::newton && N > 200) {
    o.refine_start_N = 200;
    o.refine_factor = 2;
  }
  long iterations = 0;
  for (auto _ : state) {
    pardel::Trajectory tr = pardel::linear_guess(p);
    const pardel::Summary s = pardel::solve(p, o, tr);
    if (!s.converged()) return state.SkipWithError(s.brief_report().c_str());
    iterations = s.iterations;
  }
  state.counters["iterations"] = static_cast<double>(iterations);
}
void BM_NewtonSolve(benchmark::State& state) { solve_to_tol(state, pardel::Method::newton); }

void sizes(benchmark::internal::Benchmark* b, long max_n, int max_threads = 2) {
  for (long n = 100; n <= max_n; n *= 10)
    for (int th = 1; th <= max_threads; ++th) b->Args({n, th});
}

}  // namespace

BENCHMARK(BM_SweepKernelsOnly)->Apply([](auto* b) { sizes(b, 10000000); })->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_JacobiNewtonSweep)
    ->Apply([](auto* b) { sizes(b, 10000000); })
    ->UseManualTime()
    ->Iterations(3)
    ->Unit(benchmark::kMicrosecond);
// Newton against threads is in pardel-bench-suite scaling (one solve per configuration).
BENCHMARK(BM_NewtonSolve)->Apply([](auto* b) { sizes(b, 1000000, 1); })->Iterations(2)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
