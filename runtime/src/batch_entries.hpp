/**
 * @file batch_entries.hpp
 * What one entry of a batch is (its problem and its initial guess), shared by the batch on CPU
 * cores (batch.cpp) and on the CUDA device (runtime/cuda); and the device solvers that a program
 * enables (pardel::enable_cuda), which solve() and solve_batch() call for Options::device.
 */
#ifndef PARDEL_RUNTIME_BATCH_ENTRIES_HPP
#define PARDEL_RUNTIME_BATCH_ENTRIES_HPP

#include "pardel/pardel.hpp"

namespace pardel::detail {

/** The problem of one batch entry: the base with the entry's boundary values and params. */
Problem entry_problem(const Problem& base, const BatchProblem& p);

/** The entry's initial guess: its own, else the straight line where the problem allows one (else
 *  nothing, and solve() reports what is wrong with the problem). */
Trajectory entry_guess(const Problem& problem, const BatchProblem& p);

/** A batch solver of one device (solve_batch's contract). */
using DeviceBatchSolver = BatchSummary (*)(const Problem& base, const Options& options,
                                           const std::vector<BatchProblem>& problems);

/** Registers the solver of `device` (Device::cpu is solve_batch itself and is not registered). */
void set_device_batch_solver(Device device, DeviceBatchSolver solver);

/** solve() on options.device: the problem as a batch of one on that device's solver; without one,
 *  or when it refuses, invalid_input with the reason (the trajectory is left as it was). */
Summary solve_on_device(const Problem& problem, const Options& options, Trajectory& trajectory);

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_BATCH_ENTRIES_HPP
