// Tests of solving sweep variants (pardel/app/sweep.hpp) on the seed's Zermelo
// scene with a handful of random guesses: every reported solution is converged, the solutions are
// distinct, and solving again from a solution's trajectory reproduces it.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "pardel/app/outputs.hpp"
#include "pardel/pardel.hpp"
#include "pardel/app/sweep.hpp"

namespace {

using namespace pardel;
using namespace pardel::app;

const std::string kName = std::string(PARDEL_SCENES_DIR) + "/sweeps/test.toml";

const pardel_model* resolve(const std::string& name) { return find_model(name); }

Sweep zermelo_sweep(int count, const std::string& extra = "") {
  return parse_sweep("scene = \"../zermelo_1.toml\"\nset = [\"solver.method=newton\", \"solver.max_iterations=500\"]\n"
                     "[random_guesses]\ncount = " +
                         std::to_string(count) + "\nseed = 3\nbox = { min = [-1, -2], max = [8, 7] }\n" + extra,
                     kName, {}, resolve);
}

TEST(SweepSolve, SolutionsAreConvergedDistinctAndReproducedFromTheirTrajectories) {
  const Sweep sweep = zermelo_sweep(8);
  const std::vector<VariantResult> results = run_variants_over_ranks(sweep, 1, 0, 1);
  ASSERT_EQ(results.size(), 8u);
  for (std::size_t i = 0; i < results.size(); ++i) EXPECT_EQ(results[i].id, static_cast<int>(i));
  std::vector<int> solution_of;
  const std::vector<Solution> solutions = group_solutions(results, sweep.grouping, &solution_of);
  ASSERT_FALSE(solutions.empty());
  const Scene& scene = sweep.configurations[0];
  for (const Solution& s : solutions) {
    const VariantResult& r = results[s.first_variant];
    ASSERT_TRUE(r.converged()) << s.id;
    // Converged: the DEL residual of the stored trajectory, recomputed here, is the reported one up to
    // the round-off of summing DEL terms of size 30 to 60 in another order (1e-12 is 100x that).
    EXPECT_NEAR(residual_norm(scene.problem, r.trajectory), r.residual, 1e-12) << s.id;
    EXPECT_LE(r.residual, 1e-8) << s.id;  // the relative tolerance: 1e-10 of DEL terms of size 30 to 60
    EXPECT_NEAR(discrete_action(scene.problem, r.trajectory), s.action, 1e-12 * std::abs(s.action)) << s.id;
    // The cost is the travel time: the summed clock along the path.
    EXPECT_NEAR(summed_clock(scene.problem, r.trajectory), s.cost, 1e-12 * s.cost) << s.id;
    // Every member of the group is the same path.
    for (int member : s.variants) {
      EXPECT_EQ(solution_of[member], s.id);
      EXPECT_LE(trajectory_distance(results[member].trajectory, r.trajectory), sweep.grouping.distance_tol);
    }
    // Solving again from the solution's own trajectory stays there.
    Trajectory again = r.trajectory;
    const Summary summary = solve(scene.problem, scene.options, again);
    EXPECT_TRUE(summary.converged()) << s.id << ": " << summary.message;
    EXPECT_LE(summary.iterations, 2) << s.id;
    EXPECT_LE(trajectory_distance(again, r.trajectory), 1e-8) << s.id;
    EXPECT_NEAR(physical_cost(scene, summary, again).value, s.cost, 1e-10 * s.cost) << s.id;
  }
  // Distinct: no two solutions are the same path.
  for (std::size_t a = 0; a < solutions.size(); ++a) {
    for (std::size_t b = a + 1; b < solutions.size(); ++b) {
      EXPECT_FALSE(same_solution(results[solutions[a].first_variant], results[solutions[b].first_variant],
                                 sweep.grouping))
          << solutions[a].id << " " << solutions[b].id;
    }
  }
  // Ranked by travel time.
  for (std::size_t a = 1; a < solutions.size(); ++a) EXPECT_LE(solutions[a - 1].cost, solutions[a].cost);
}

TEST(SweepSolve, SameAnswersForAnyThreadCount) {
  const Sweep sweep = zermelo_sweep(4);
  const std::vector<VariantResult> one = run_variants_over_ranks(sweep, 1, 0, 1);
  const std::vector<VariantResult> two = run_variants_over_ranks(sweep, 2, 0, 1);
  ASSERT_EQ(one.size(), two.size());
  for (std::size_t i = 0; i < one.size(); ++i) {
    EXPECT_EQ(one[i].status, two[i].status);
    EXPECT_EQ(one[i].iterations, two[i].iterations);
    EXPECT_EQ(one[i].action, two[i].action);
    EXPECT_EQ(one[i].trajectory.q, two[i].trajectory.q);
  }
}

TEST(SweepSolve, ANumericalFailureIsAStatusWithoutTrajectory) {
  const Sweep sweep = parse_sweep(
      "scene = \"../zermelo_1.toml\"\nset = [\"solver.method=newton\", \"solver.max_iterations=1\"]\n", kName, {},
      resolve);
  const VariantResult r = solve_variant(sweep, make_variant(sweep, 0), 1);
  EXPECT_EQ(r.status, "max_iterations");
  EXPECT_EQ(r.iterations, 1);
  EXPECT_TRUE(r.trajectory.q.empty());
  EXPECT_TRUE(group_solutions({r}, sweep.grouping).empty());
}

}  // namespace
