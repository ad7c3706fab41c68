/**
 * @file one_process.cpp
 * The topology of a solve in one process (topology.hpp): every node in this process's context,
 * reductions that are the values themselves, the whole-system Newton over LocalSpace
 * (newton.cpp), the stationary Newton, iterative refinement and the point assessment of
 * assessment.hpp.
 */
#include <algorithm>
#include <cmath>

#include "assessment.hpp"
#include "extended_assessment.hpp"
#include "iterative_refinement.hpp"
#include "topology.hpp"

namespace pardel::detail {

void OneProcess::update_times(Context& ctx, Positions positions) { detail::update_times(ctx, positions); }

void OneProcess::check_next(const Context& ctx, const StepOutcome& outcome, int* node, double* qmax) {
  *node = outcome.next_checked ? outcome.next_non_finite_node : first_non_finite_node(ctx, ctx.q_next);
  *qmax = outcome.next_max_abs;
  if (!outcome.next_checked)
    for (double v : ctx.q_next) *qmax = std::max(*qmax, std::fabs(v));
}

double OneProcess::action(Context& ctx) { return action_at(ctx, ctx.q); }

std::unique_ptr<Method_> OneProcess::make_newton(const Options& options, int dim) {
  return detail::make_newton(options, dim);
}

std::unique_ptr<Method_> OneProcess::make_stationary_newton(const Options& options, int dim) {
  return detail::make_stationary_newton(options, dim);
}

bool OneProcess::set_up(const Problem& problem, int N, int threads, const Trajectory& from, std::string* message) {
  setup_context(problem, N, threads, ctx_);
  ctx_.q = from.q;
  place_end_points(problem, N, 0, N, ctx_.dim, ctx_.q.data());
  if (!apply_constraints(problem, ctx_, message)) return false;
  if (problem.clock != ClockMode::none && from.t.size() == ctx_.t.size()) ctx_.t = from.t;
  return true;
}

bool OneProcess::set_up_resumed(const Problem& problem, const SolverState& st, int threads, std::string* message) {
  setup_context(problem, st.N, threads, ctx_);
  ctx_.q = st.trajectory.q;
  if (!apply_constraints(problem, ctx_, message)) return false;
  ctx_.t = st.trajectory.t;
  if (problem.clock == ClockMode::fixed_total_time) steps_from_times(ctx_);
  return true;
}

bool OneProcess::lagrangian_regular(const Problem&, std::string* message) {
  return detail::lagrangian_regular(ctx_, message);
}

void OneProcess::gather(bool, Trajectory& out) {
  out.N = ctx_.N;
  out.dim = ctx_.dim;
  out.t = ctx_.t;
  out.q = ctx_.q;
}

void OneProcess::refine(const Options& options, Summary& summary) { refine_solution(ctx_, options, summary); }

void OneProcess::assess(const Options&, PointAssessment& out) { detail::assess(ctx_, out); }

void OneProcess::interior_inertia(Inertia& out) { out = detail::interior_inertia(ctx_, 0, ctx_.N); }

bool OneProcess::assess_extended(PointAssessment& out) { return detail::assess_extended(ctx_, out); }

}  // namespace pardel::detail
