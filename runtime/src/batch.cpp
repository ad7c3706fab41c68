/**
 * @file batch.cpp
 * solve_batch: many independent problems solved at once, one problem per OpenMP thread (dynamic
 * schedule), each by solve() with one thread, so that every entry is solve()'s answer for that
 * problem whatever the number of threads; the batch's memory is checked before anything is
 * allocated, and Options::keep_going stops it.
 */
#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <new>
#include <string>
#include <utility>

#include "batch_entries.hpp"
#include "engine.hpp"
#include "pardel/memory.hpp"
#include "pardel/pardel.hpp"

namespace pardel {
namespace {

/** Why the whole batch is refused before solving ("" when it is not): options it does not take,
 *  or memory. `threads` problems are solved at once, each with `inner` options. */
std::string batch_refusal(const Problem& base, const Options& options, const Options& inner, std::size_t count,
                          int threads) {
  std::string error;
  if (!options.is_valid(&error)) return error;
  if (options.resume_from) return "solve_batch does not resume solves (Options::resume_from is set)";
  if (!base.model || base.N < 2) return "";  // each problem's solve reports it
  // The solves running at once, each at its peak while iterating or assessing its point (no CSV
  // text is written), and the trajectories the batch returns.
  const MemoryEstimate one = estimate_solve_memory(base, inner);
  const double per_solve = std::max(one.solve, one.assessment);
  const double result = (static_cast<double>(base.N) + 1) * (base.model->dim + 1) * 8.0 + sizeof(BatchEntry);
  MemoryEstimate all;
  all.peak = std::min<double>(threads, static_cast<double>(count)) * per_solve + static_cast<double>(count) * result;
  all.largest = std::to_string(std::min<std::size_t>(static_cast<std::size_t>(threads), count)) +
                " solves at once and " + std::to_string(count) + " results";
  Options at_once = inner;  // the address space each of the batch's threads reserves
  at_once.threads = threads;
  const std::string refusal = memory_refusal(base, at_once, all, machine_memory(all.peak));
  if (refusal.empty()) return "";
  return "a batch of " + std::to_string(count) + " problems: " + refusal +
         " (for a batch: or fewer problems per call, or fewer threads)";
}

}  // namespace

namespace detail {

Problem entry_problem(const Problem& base, const BatchProblem& p) {
  Problem problem = base;
  if (!p.q0.empty()) problem.q0 = p.q0;
  if (!p.qN.empty()) problem.qN = p.qN;
  if (!p.params.empty()) problem.params = p.params;
  return problem;
}

Trajectory entry_guess(const Problem& problem, const BatchProblem& p) {
  if (p.guess.N > 0) return p.guess;
  const std::size_t dim = problem.model ? static_cast<std::size_t>(problem.model->dim) : 0;
  if (!problem.model || problem.N < 2 || problem.q0.size() != dim || problem.qN.size() != dim) return Trajectory{};
  return linear_guess(problem);
}

namespace {
std::atomic<DeviceBatchSolver> cuda_solver{nullptr};

std::string no_device_solver(Device device) {
  return std::string("device ") + to_string(device) +
         ": this program has no solver for it (pardel built without PARDEL_WITH_CUDA, or a program that did not "
         "link pardel::cuda and call pardel::enable_cuda(); docs/gpu.md)";
}
}  // namespace

void set_device_batch_solver(Device device, DeviceBatchSolver solver) {
  if (device == Device::cuda) cuda_solver.store(solver);
}

Summary solve_on_device(const Problem& problem, const Options& options, Trajectory& trajectory) {
  Summary summary;
  summary.method = options.method;
  summary.N = problem.N;
  const DeviceBatchSolver solver = options.device == Device::cuda ? cuda_solver.load() : nullptr;
  if (!solver) {
    summary.message = no_device_solver(options.device);
    return summary;
  }
  std::vector<BatchProblem> one(1);
  if (trajectory.N > 0) one[0].guess = trajectory;
  BatchSummary batch = solver(problem, options, one);
  if (!batch.refusal.empty() || batch.entries.size() != 1) {
    summary.message = std::string("device ") + to_string(options.device) + ": " + batch.refusal;
    return summary;
  }
  if (batch.entries[0].trajectory.N > 0) trajectory = std::move(batch.entries[0].trajectory);
  return batch.entries[0].summary;
}

}  // namespace detail

using detail::entry_guess;
using detail::entry_problem;

BatchSummary solve_batch(const Problem& base, const Options& options, const std::vector<BatchProblem>& problems) {
  if (options.device == Device::cuda) {
    const detail::DeviceBatchSolver solver = detail::cuda_solver.load();
    if (solver) return solver(base, options, problems);
    BatchSummary refused;
    refused.refusal = detail::no_device_solver(options.device);
    return refused;
  }
  const auto start = std::chrono::steady_clock::now();
  BatchSummary batch;
  const int threads = std::max(1, std::min(detail::resolve_threads(options.threads),
                                           static_cast<int>(std::max<std::size_t>(problems.size(), 1))));
  batch.threads = threads;
  // Each problem's solve: one thread, the batch's stop in place of the caller's callbacks.
  std::atomic<bool> stop{false};
  auto keep_going = [&stop, &options]() {
    if (stop.load(std::memory_order_relaxed)) return false;
    if (options.keep_going && !options.keep_going()) {
      stop.store(true, std::memory_order_relaxed);
      return false;
    }
    return true;
  };
  Options inner = options;
  inner.threads = 1;
  inner.keep_going = keep_going;
  inner.on_iteration = [&keep_going](const IterationRecord&) { return keep_going(); };
  batch.refusal = batch_refusal(base, options, inner, problems.size(), threads);
  if (!batch.refusal.empty()) return batch;
  batch.entries.resize(problems.size());
  const long count = static_cast<long>(problems.size());
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (long i = 0; i < count; ++i) {
    BatchEntry& entry = batch.entries[static_cast<std::size_t>(i)];
    if (!keep_going()) {
      entry.summary.termination = Termination::interrupted;
      entry.summary.message = "not started: the batch was interrupted";
      continue;
    }
    const BatchProblem& p = problems[static_cast<std::size_t>(i)];
    try {
      const Problem problem = entry_problem(base, p);
      entry.trajectory = entry_guess(problem, p);
      entry.summary = solve(problem, inner, entry.trajectory);
    } catch (const std::bad_alloc&) {
      entry = BatchEntry{};
      entry.summary.message = "out of memory (std::bad_alloc) while solving this problem of the batch";
    } catch (const std::exception& error) {
      entry = BatchEntry{};
      entry.summary.message = error.what();
    }
  }
  for (const BatchEntry& e : batch.entries) batch.converged += e.summary.converged() ? 1 : 0;
  batch.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return batch;
}

}  // namespace pardel
