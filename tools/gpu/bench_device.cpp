/**
 * @file bench_device.cpp
 * The GPU benchmark (run by tools/gpu/run.sh): solve_batch_cuda against solve_batch on all CPU
 * cores of the same machine, with the same options, on
 *  - batches of Zermelo routes (the seed's four vortices, N = 80) and fuel-navigation variants
 *    (N = 100) from random polyline guesses, by Jacobi-Newton to the default tolerance; and by
 *    Newton (Zermelo, and fuel navigation at N = 200), against the CPU's Newton;
 *  - one fuel-navigation problem at N = 10^7: the time of one Jacobi-Newton sweep;
 *  - OpenMP scaling of the CPU batch and of the CPU sweeps from 1 to all cores.
 * CPU sweep times are differences of two solves with different sweep counts, so that solve()'s
 * setup (allocation, first touch, the guess) is not counted as sweeping.
 * The CPU batch solves a sample of the problems (--cpu-sample): per-problem throughput is compared,
 * and the sample's answers are compared with the device's (status, iterations, largest difference).
 * Each batch is also written for the JAX peer (tools/gpu/jax_peer.py): a JSON description and the
 * guesses as raw float64, and the device's answers beside them.
 *
 * --profile 1 runs only a few sweeps (--profile-sweeps, default 4) of the Zermelo batch and of the
 * large-N problem and prints their time per sweep, for a profiler (tools/gpu/run.sh runs it under
 * Nsight Compute where `ncu` is on PATH).
 *
 *   bench_device --out DIR [--batch 10000] [--cpu-sample 64] [--sweep-N 10000000] [--batches-only 1]
 *                [--profile 1 [--profile-sweeps 4]]
 */
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "pardel/cuda.hpp"
#include "pardel/pardel.hpp"

extern "C" const pardel_model fuel_nav_model, zermelo_model;

namespace {

struct Args {
  std::string out = ".";
  int batch = 10000;
  int cpu_sample = 64;
  int sweep_N = 10000000;
  int scaling_sample = 32;
  bool batches_only = false;  ///< --batches-only 1: no large-N sweep, no scaling
  bool profile = false;       ///< --profile 1: a few sweeps of each kind, nothing compared
  long profile_sweeps = 4;    ///< --profile-sweeps: their number
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

pardel::Options jacobi_newton(long max_iterations) {
  pardel::Options o;
  o.method = pardel::Method::jacobi_newton;
  o.max_iterations = max_iterations;
  o.error_estimate = false;
  o.iterative_refinement = pardel::Refinement::off;
  return o;
}

/** Polyline guesses through the given interior points, each moved by up to `jitter`. */
std::vector<pardel::BatchProblem> polyline_batch(const pardel::Problem& base, const std::vector<std::vector<double>>& inner,
                                                 double jitter, int B, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  std::vector<pardel::BatchProblem> out(static_cast<std::size_t>(B));
  for (pardel::BatchProblem& bp : out) {
    std::vector<std::vector<double>> points{base.q0};
    for (const auto& p : inner) points.push_back({p[0] + u(rng), p[1] + u(rng)});
    points.push_back(base.qN);
    bp.guess = pardel::polyline_guess(base, points);
  }
  return out;
}

void write_raw(const std::string& path, const std::vector<double>& v) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(double)));
}

/** The batch for the JAX peer: the JSON it reads and the guesses; the device's answers beside. */
void write_for_peer(const Args& a, const std::string& name, const pardel::Problem& base,
                    const std::vector<pardel::BatchProblem>& batch, const pardel::BatchSummary& gpu,
                    const pardel::Options& o, int check_every) {
  std::vector<double> guesses, answers;
  for (std::size_t b = 0; b < batch.size(); ++b) {
    guesses.insert(guesses.end(), batch[b].guess.q.begin(), batch[b].guess.q.end());
    answers.insert(answers.end(), gpu.entries[b].trajectory.q.begin(), gpu.entries[b].trajectory.q.end());
  }
  write_raw(a.out + "/" + name + "_guesses.bin", guesses);
  write_raw(a.out + "/" + name + "_pardel.bin", answers);
  std::string params;
  for (int i = 0; i < base.model->nparams; ++i)
    params += (i ? ", " : "") + std::to_string(base.model->param_defaults[i]);
  std::ofstream f(a.out + "/" + name + ".json");
  f << "{\"model\": \"" << base.model->name << "\", \"discretization\": \"" << base.discretization->name
    << "\", \"N\": " << base.N << ", \"t0\": " << base.t0 << ", \"T\": " << base.T << ", \"dim\": " << base.model->dim
    << ", \"params\": [" << params << "], \"B\": " << batch.size() << ", \"guesses\": \"" << name
    << "_guesses.bin\", \"rtol\": " << o.rtol << ", \"tol\": " << o.tol << ", \"damping\": " << o.damping
    << ", \"max_sweeps\": " << o.max_iterations << ", \"check_every\": " << check_every << "}\n";
}

/** Wall time of solve() doing `sweeps` Jacobi-Newton sweeps from the straight line. */
double sweep_seconds(const pardel::Problem& p, long sweeps, int threads, pardel::Summary* summary = nullptr) {
  pardel::Options o = jacobi_newton(sweeps);
  o.threads = threads;
  pardel::Trajectory tr = pardel::linear_guess(p);
  const auto t0 = std::chrono::steady_clock::now();
  const pardel::Summary s = pardel::solve(p, o, tr);
  const double seconds = seconds_since(t0);
  if (summary) *summary = s;
  return seconds;
}

struct BatchRow {
  std::string name;
  int B = 0, N = 0;
  double device_s = 0, sweeps_s = 0, host_s = 0;
  long converged = 0, sweeps = 0;
  long min_it = 0, median_it = 0, max_it = 0;
  int sample = 0, threads = 0;
  double cpu_s = 0;
  long cpu_converged = 0;
  int same_status = 0, same_iterations = 0;
  int same_answer = 0;  ///< answers within 1e-7 of the CPU's (Newton may reach another minimum)
  double max_diff = 0;
};

/** One batch on the device and a sample of it on all CPU cores, by `o.method`; the batch is
 *  written for the JAX peer when `for_peer`. */
BatchRow run_batch(const Args& a, const std::string& name, const pardel::Problem& base,
                   const std::vector<std::vector<double>>& inner, double jitter, const pardel::Options& o,
                   bool for_peer) {
  BatchRow row;
  row.name = name;
  row.B = a.batch;
  row.N = base.N;
  const auto batch = polyline_batch(base, inner, jitter, a.batch, 1);
  pardel::CudaSettings settings;
  settings.assess = false;  // timed: the device's part alone (the assessment is a host step)
  pardel::CudaBatchTimes times;
  // Warm-up (module load, first allocations) on a small batch.
  pardel::solve_batch_cuda(base, o, std::vector<pardel::BatchProblem>(batch.begin(), batch.begin() + 16), settings);
  const pardel::BatchSummary gpu = pardel::solve_batch_cuda(base, o, batch, settings, &times);
  if (!gpu.refusal.empty()) {
    std::printf("%s: refused: %s\n", name.c_str(), gpu.refusal.c_str());
    return row;
  }
  row.device_s = times.upload + times.sweeps + times.download;
  row.sweeps_s = times.sweeps;
  row.host_s = times.host;
  row.converged = gpu.converged;
  row.sweeps = times.sweeps_run;
  std::vector<long> its;
  for (const auto& e : gpu.entries) its.push_back(e.summary.iterations);
  std::sort(its.begin(), its.end());
  row.min_it = its.front();
  row.median_it = its[its.size() / 2];
  row.max_it = its.back();
  if (for_peer) write_for_peer(a, name, base, batch, gpu, o, settings.check_every);
  // The CPU sample, all cores.
  row.sample = std::min(a.cpu_sample, a.batch);
  const std::vector<pardel::BatchProblem> sample(batch.begin(), batch.begin() + row.sample);
  pardel::Options cpu_o = o;
  cpu_o.threads = 0;
  const auto t0 = std::chrono::steady_clock::now();
  const pardel::BatchSummary cpu = pardel::solve_batch(base, cpu_o, sample);
  row.cpu_s = seconds_since(t0);
  row.threads = cpu.threads;
  row.cpu_converged = cpu.converged;
  for (int b = 0; b < row.sample; ++b) {
    const auto& g = gpu.entries[static_cast<std::size_t>(b)];
    const auto& c = cpu.entries[static_cast<std::size_t>(b)];
    row.same_status += g.summary.termination == c.summary.termination;
    row.same_iterations += g.summary.iterations == c.summary.iterations;
    double diff = 0;
    for (std::size_t i = 0; i < c.trajectory.q.size(); ++i)
      diff = std::max(diff, std::fabs(g.trajectory.q[i] - c.trajectory.q[i]));
    row.max_diff = std::max(row.max_diff, diff);
    row.same_answer += diff <= 1e-7;
  }
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--out") a.out = v;
    else if (k == "--batch") a.batch = std::atoi(v.c_str());
    else if (k == "--cpu-sample") a.cpu_sample = std::atoi(v.c_str());
    else if (k == "--sweep-N") a.sweep_N = std::atoi(v.c_str());
    else if (k == "--scaling-sample") a.scaling_sample = std::atoi(v.c_str());
    else if (k == "--batches-only") a.batches_only = v == "1";
    else if (k == "--profile") a.profile = v == "1";
    else if (k == "--profile-sweeps") a.profile_sweeps = std::atol(v.c_str());
    else {
      std::fprintf(stderr, "bench_device: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  std::string why;
  if (!pardel::cuda_device_available(&why)) {
    std::fprintf(stderr, "bench_device: %s\n", why.c_str());
    return 1;
  }
  std::FILE* json = std::fopen((a.out + "/bench_device.json").c_str(), "w");
  std::fprintf(json, "{\n");

  // Batches.
  pardel::Problem zermelo;
  zermelo.model = &zermelo_model;
  zermelo.discretization = &zermelo_model.discretizations[0];
  zermelo.T = 1;
  zermelo.N = 80;
  zermelo.q0 = {0, 0};
  zermelo.qN = {6, 2};
  pardel::Problem fuel;
  fuel.model = &fuel_nav_model;
  fuel.discretization = &fuel_nav_model.discretizations[0];
  fuel.T = 30;
  fuel.N = 100;
  fuel.q0 = {0, 0};
  fuel.qN = {6, 5};
  if (a.profile) {
    // A few sweeps of each kind (--profile-sweeps), timed by the device's events.
    pardel::CudaSettings s;
    s.assess = false;
    s.check_every = static_cast<int>(a.profile_sweeps) + 1;
    pardel::CudaBatchTimes tz, tf;
    const auto batch = polyline_batch(zermelo, {{1, 3.5}, {4, 5.5}}, 0.5, a.batch, 1);
    const pardel::BatchSummary z = pardel::solve_batch_cuda(zermelo, jacobi_newton(a.profile_sweeps), batch, s, &tz);
    pardel::Problem big = fuel;
    big.N = a.sweep_N;
    const pardel::BatchSummary f =
        pardel::solve_batch_cuda(big, jacobi_newton(a.profile_sweeps), std::vector<pardel::BatchProblem>(1), s, &tf);
    std::printf("profile runs: Zermelo batch of %d (N = 80): %s, %.1f us per sweep (%ld sweeps); fuel navigation at "
                "N = %d: %s, %.3f ms per sweep\n",
                a.batch, z.refusal.empty() ? "done" : z.refusal.c_str(), tz.sweeps / std::max<long>(1, tz.sweeps_run) * 1e6,
                tz.sweeps_run, a.sweep_N, f.refusal.empty() ? "done" : f.refusal.c_str(),
                tf.sweeps / std::max<long>(1, tf.sweeps_run) * 1e3);
    std::fprintf(json, "  \"profile\": {\"zermelo_us\": %.6g, \"fuel_ms\": %.6g}\n}\n",
                 tz.sweeps / std::max<long>(1, tz.sweeps_run) * 1e6, tf.sweeps / std::max<long>(1, tf.sweeps_run) * 1e3);
    std::fclose(json);
    return 0;
  }
  std::vector<BatchRow> rows;
  rows.push_back(run_batch(a, "zermelo_N80", zermelo, {{1, 3.5}, {4, 5.5}}, 0.5, jacobi_newton(100000), true));
  rows.push_back(run_batch(a, "fuel_nav_N100", fuel, {{2, 1.5}, {4, 3.5}}, 1.0, jacobi_newton(100000), true));
  // Newton (one problem per device thread; on the CPU the trust-region Newton of solve()).
  pardel::Options newton = jacobi_newton(500);
  newton.method = pardel::Method::newton;
  pardel::Problem fuel200 = fuel;
  fuel200.N = 200;
  rows.push_back(run_batch(a, "newton_zermelo_N80", zermelo, {{1, 3.5}, {4, 5.5}}, 0.5, newton, false));
  rows.push_back(run_batch(a, "newton_fuel_N200", fuel200, {{2, 1.5}, {4, 3.5}}, 1.0, newton, false));
  std::printf("\nbatches: Jacobi-Newton (newton_*: Newton) to the default tolerance (rtol 1e-10), random polyline "
              "guesses; \"its\" are sweeps or Newton iterations\n");
  std::printf("%-18s %6s %4s | %9s %9s %8s %9s | %6s %7s %9s %10s | %7s %7s %7s %9s | %8s\n", "batch", "B", "N",
              "device s", "sweeps s", "conv", "its med", "sample", "threads", "CPU s", "CPU conv", "status=",
              "iters=", "answer=", "max diff", "speed-up");
  std::fprintf(json, "  \"batches\": [\n");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const BatchRow& r = rows[i];
    const double per_problem_gpu = r.device_s / std::max(1, r.B), per_problem_cpu = r.cpu_s / std::max(1, r.sample);
    const double speedup = per_problem_cpu / per_problem_gpu;
    std::printf("%-18s %6d %4d | %9.4f %9.4f %8ld %9ld | %6d %7d %9.3f %10ld | %7d %7d %7d %9.2e | %8.1f\n",
                r.name.c_str(), r.B, r.N, r.device_s, r.sweeps_s, r.converged, r.median_it, r.sample, r.threads,
                r.cpu_s, r.cpu_converged, r.same_status, r.same_iterations, r.same_answer, r.max_diff, speedup);
    std::fprintf(json,
                 "    {\"name\": \"%s\", \"B\": %d, \"N\": %d, \"device_seconds\": %.6g, \"sweeps_seconds\": %.6g, "
                 "\"host_seconds\": %.6g, \"converged\": %ld, \"sweeps_run\": %ld, \"iterations_min\": %ld, "
                 "\"iterations_median\": %ld, \"iterations_max\": %ld, \"cpu_sample\": %d, \"cpu_threads\": %d, "
                 "\"cpu_seconds\": %.6g, \"cpu_converged\": %ld, \"same_status\": %d, \"same_iterations\": %d, "
                 "\"same_answer\": %d, \"max_diff\": %.3g, \"speedup_per_problem\": %.4g}%s\n",
                 r.name.c_str(), r.B, r.N, r.device_s, r.sweeps_s, r.host_s, r.converged, r.sweeps, r.min_it,
                 r.median_it, r.max_it, r.sample, r.threads, r.cpu_s, r.cpu_converged, r.same_status,
                 r.same_iterations, r.same_answer, r.max_diff, speedup, i + 1 < rows.size() ? "," : "");
  }
  std::fprintf(json, "  ]%s\n", a.batches_only ? "\n}" : ",");
  if (a.batches_only) {
    std::fclose(json);
    return 0;
  }

  // One sweep at large N (fuel navigation, straight-line guess): the device's time per sweep over
  // 200 sweeps, and the CPU's over 20 sweeps on all cores.
  {
    pardel::Problem big = fuel;
    big.N = a.sweep_N;
    std::vector<pardel::BatchProblem> one(1);
    pardel::Options o = jacobi_newton(200);
    pardel::CudaSettings s;
    s.check_every = 201;
    s.assess = false;
    pardel::CudaBatchTimes t;
    pardel::solve_batch_cuda(big, jacobi_newton(3), one, s);  // warm-up
    const pardel::BatchSummary g = pardel::solve_batch_cuda(big, o, one, s, &t);
    const double per_sweep = t.sweeps / std::max<long>(1, t.sweeps_run);
    // Bytes a sweep must move at least: read the iterate, write the next (16 bytes per node and
    // coordinate); the grid arrays are read too (16 bytes per node).
    const double bytes = (static_cast<double>(a.sweep_N) + 1) * (2 * 16.0 + 16.0);
    // The CPU's cost per sweep without solve()'s setup: the difference of 40 and 20 sweeps.
    pardel::Summary cs;
    const double cpu_per_sweep = (sweep_seconds(big, 40, 0, &cs) - sweep_seconds(big, 20, 0, &cs)) / 20;
    std::printf("\nsweep at N = %d (fuel navigation): device %.3f ms per sweep (%ld sweeps, %s), %.0f GB/s of the "
                "least traffic; CPU (%d threads) %.3f ms per sweep; ratio %.1f\n",
                a.sweep_N, per_sweep * 1e3, t.sweeps_run,
                g.entries.empty() ? g.refusal.c_str() : pardel::to_string(g.entries[0].summary.termination),
                bytes / per_sweep / 1e9, cs.threads, cpu_per_sweep * 1e3, cpu_per_sweep / per_sweep);
    std::fprintf(json,
                 "  \"sweep\": {\"N\": %d, \"device_ms\": %.6g, \"sweeps\": %ld, \"least_bytes\": %.6g, "
                 "\"device_GBps\": %.6g, \"cpu_threads\": %d, \"cpu_ms\": %.6g},\n",
                 a.sweep_N, per_sweep * 1e3, t.sweeps_run, bytes, bytes / per_sweep / 1e9, cs.threads,
                 cpu_per_sweep * 1e3);
  }

  // OpenMP scaling on this machine's cores: the CPU batch (Zermelo sample) and the CPU sweeps.
  {
    const int cores = omp_get_num_procs();
    const auto batch = polyline_batch(zermelo, {{1, 3.5}, {4, 5.5}}, 0.5, a.scaling_sample, 2);
    pardel::Problem big = fuel;
    big.N = 1000000;
    std::printf("\nOpenMP scaling (%d cores): batch of %d Zermelo routes (N = 80), and 50 sweeps at N = 10^6 (the "
                "difference of 60 and 10 sweeps: solve()'s setup left out)\n",
                cores,
                a.scaling_sample);
    std::printf("%7s | %9s %10s | %9s %10s\n", "threads", "batch s", "efficiency", "sweeps s", "efficiency");
    std::fprintf(json, "  \"scaling\": [\n");
    double batch1 = 0, sweep1 = 0;
    for (int threads = 1; threads <= cores; threads *= 2) {
      pardel::Options o = jacobi_newton(100000);
      o.threads = threads;
      auto t0 = std::chrono::steady_clock::now();
      pardel::solve_batch(zermelo, o, batch);
      const double tb = seconds_since(t0);
      const double ts = sweep_seconds(big, 60, threads) - sweep_seconds(big, 10, threads);  // 50 sweeps, no setup
      if (threads == 1) {
        batch1 = tb;
        sweep1 = ts;
      }
      std::printf("%7d | %9.3f %10.2f | %9.3f %10.2f\n", threads, tb, batch1 / (tb * threads), ts,
                  sweep1 / (ts * threads));
      std::fprintf(json, "    {\"threads\": %d, \"batch_seconds\": %.6g, \"sweeps_seconds\": %.6g}%s\n", threads, tb, ts,
                   threads * 2 <= cores ? "," : "");
    }
    std::fprintf(json, "  ]\n}\n");
  }
  std::fclose(json);
  return 0;
}
