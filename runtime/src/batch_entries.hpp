/**
 * @file batch_entries.hpp
 * What one entry of a batch is (its problem and its initial guess), shared by the batch on CPU
 * cores (batch.cpp) and on the CUDA device (runtime/cuda).
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

}  // namespace pardel::detail

#endif  // PARDEL_RUNTIME_BATCH_ENTRIES_HPP
