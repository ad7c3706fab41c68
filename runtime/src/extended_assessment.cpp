/**
 * @file extended_assessment.cpp
 * The point assessment with the Hessian in extended precision (extended_assessment.hpp).
 */
#include "extended_assessment.hpp"

#include <string>

#include "assessment.hpp"
#include "extended_node_system.hpp"

namespace pardel::detail {

bool beyond_double(const PointAssessment& point) {
  switch (point.kind) {
    case PointKind::unknown:
      return false;
    case PointKind::saddle:
    case PointKind::degenerate:
      return true;
    case PointKind::minimum:
      return notes_round_off_bound(point.lambda_min, point.lambda_max);
  }
  return false;
}

bool assess_extended(Context& ctx, PointAssessment& out) {
  if (!ctx.disc || !ctx.disc->full_extended || ctx.N < 2 || !times_outside_the_problem(ctx)) return false;
  ExtendedNodeSystem system;
  Inertia in;
  if (!system.evaluate(ctx, ctx.q) || !system.factor(&in)) return false;
  PointAssessment point;
  point.lambda_max = system.gershgorin_bound();
  point.positive = in.positive - fixed_components(ctx);
  point.negative = in.negative;
  point.zero = in.zero;
  if (classify_indefinite(point)) {
    if (point.kind == PointKind::degenerate)
      point.note = "degenerate: the Hessian of the action, counted in extended precision, has " +
                   std::to_string(in.zero) +
                   " eigenvalue(s) that are zero within its rounding and no negative one; the solution is not "
                   "isolated (a family of trajectories, or a Lagrangian that does not determine the motion) or "
                   "the Hessian is too ill-conditioned for extended precision to tell";
  } else {
    assess_minimum(ctx, point.lambda_max, [&system](const double* b, double* x) { system.solve(b, x); }, point);
    if (point.kind == PointKind::unknown) {  // interrupted: the double assessment stands
      return false;
    }
  }
  point.note += "; counted with the Hessian in extended precision, whose condition number is beyond double "
                "precision here";
  if (point.kind == PointKind::minimum && notes_round_off_bound(point.lambda_min, point.lambda_max))
    point.note += " (iterative refinement in extended precision corrects that round-off of a double solve where it "
                  "runs: refinement_note)";
  out = point;
  return true;
}

}  // namespace pardel::detail
