// Tests of the grouping of sweep results into distinct local solutions (pardel/app/sweep.hpp) on
// synthetic results: what merges, what stays apart, the order of ids and ranks, the CSV table.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "pardel/app/sweep.hpp"

namespace {

using namespace pardel;
using namespace pardel::app;

/** A converged result whose 1-D trajectory has nodes `q` (t = k). */
VariantResult result(int id, double cost, double action, std::vector<double> q, int configuration = 0) {
  VariantResult r;
  r.id = id;
  r.configuration = configuration;
  r.status = "converged";
  r.cost = cost;
  r.action = action;
  r.residual = 1e-12;
  r.certificate_valid = true;
  r.hessian_positive_definite = true;
  r.trajectory.N = static_cast<int>(q.size()) - 1;
  r.trajectory.dim = 1;
  for (std::size_t k = 0; k < q.size(); ++k) r.trajectory.t.push_back(static_cast<double>(k));
  r.trajectory.q = std::move(q);
  return r;
}

VariantResult failed(int id, const char* status) {
  VariantResult r;
  r.id = id;
  r.status = status;
  return r;
}

TEST(SweepGrouping, IdenticalResultsMergeIntoOneSolutionRepresentedByTheFirst) {
  const std::vector<VariantResult> results = {result(0, 5.0, 2.0, {0, 1, 2}), result(1, 5.0, 2.0, {0, 1, 2}),
                                              result(2, 5.0, 2.0 + 1e-12, {0, 1 + 1e-9, 2})};
  std::vector<int> solution_of;
  const auto solutions = group_solutions(results, GroupingOptions{}, &solution_of);
  ASSERT_EQ(solutions.size(), 1u);
  EXPECT_EQ(solutions[0].first_variant, 0);
  EXPECT_EQ(solutions[0].variants, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(solution_of, (std::vector<int>{1, 1, 1}));
}

TEST(SweepGrouping, SameActionButDistantPathsAreDistinct) {
  const std::vector<VariantResult> results = {result(0, 5.0, 2.0, {0, 1, 2}), result(1, 5.0, 2.0, {0, -1, 2})};
  EXPECT_EQ(group_solutions(results, GroupingOptions{}).size(), 2u);
}

TEST(SweepGrouping, InfiniteActionsLeaveTheGroupingToThePaths) {
  // A singular fixed end (L = x'^2/2 + 1/x with x(0) = 0) makes every variant's action +inf: six
  // variants on one path were six solutions, inf - inf being NaN.
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<VariantResult> results = {result(0, inf, inf, {0, 1, 2}), result(1, inf, inf, {0, 1, 2}),
                                              result(2, inf, inf, {0, -1, 2}), result(3, inf, -inf, {0, 1, 2})};
  std::vector<int> solution_of;
  const auto solutions = group_solutions(results, GroupingOptions{}, &solution_of);
  ASSERT_EQ(solutions.size(), 3u);
  EXPECT_EQ(solution_of[0], solution_of[1]);
  EXPECT_NE(solution_of[0], solution_of[2]);
  EXPECT_NE(solution_of[0], solution_of[3]);
}

TEST(SweepGrouping, ClosePathsButDifferentActionsAreDistinct) {
  const std::vector<VariantResult> results = {result(0, 5.0, 2.0, {0, 1, 2}), result(1, 5.0, 2.1, {0, 1, 2})};
  EXPECT_EQ(group_solutions(results, GroupingOptions{}).size(), 2u);
}

TEST(SweepGrouping, TolerancesDecide) {
  const std::vector<VariantResult> results = {result(0, 5.0, 100.0, {0, 1, 2}),
                                              result(1, 5.0, 100.0 + 5e-5, {0, 1.005, 2})};
  GroupingOptions tight;  // action_tol 1e-8 relative, distance_tol 1e-4
  EXPECT_EQ(group_solutions(results, tight).size(), 2u);
  GroupingOptions action_only_loose;
  action_only_loose.action_tol = 1e-6;  // |dS| = 5e-5 <= 1e-6 * 100
  EXPECT_EQ(group_solutions(results, action_only_loose).size(), 2u);  // distance 0.005 > 1e-4
  GroupingOptions loose = action_only_loose;
  loose.distance_tol = 0.01;
  EXPECT_EQ(group_solutions(results, loose).size(), 1u);
}

TEST(SweepGrouping, FailedVariantsBelongToNoSolution) {
  const std::vector<VariantResult> results = {failed(0, "max_iterations"), result(1, 3.0, 1.0, {0, 1, 2}),
                                              failed(2, "error")};
  std::vector<int> solution_of;
  const auto solutions = group_solutions(results, GroupingOptions{}, &solution_of);
  ASSERT_EQ(solutions.size(), 1u);
  EXPECT_EQ(solutions[0].first_variant, 1);
  EXPECT_EQ(solution_of, (std::vector<int>{0, 1, 0}));
}

TEST(SweepGrouping, IdsFollowCostAndRanksRestartPerConfiguration) {
  const std::vector<VariantResult> results = {
      result(0, 9.0, 3.0, {0, 3, 2}, 0), result(1, 7.0, 2.0, {0, 1, 2}, 0), result(2, 8.0, 2.5, {0, 2, 2}, 0),
      result(3, 7.0, 2.0, {0, 1, 2}, 1),  // the same numbers as variant 1, another configuration
      result(4, 6.0, 1.0, {0, 0, 2}, 1)};
  std::vector<int> solution_of;
  const auto s = group_solutions(results, GroupingOptions{}, &solution_of);
  ASSERT_EQ(s.size(), 5u);
  const int expected_first[] = {1, 2, 0, 4, 3};
  const int expected_rank[] = {1, 2, 3, 1, 2};
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(s[i].id, i + 1);
    EXPECT_EQ(s[i].first_variant, expected_first[i]) << i;
    EXPECT_EQ(s[i].rank, expected_rank[i]) << i;
  }
  EXPECT_EQ(solution_of, (std::vector<int>{3, 1, 2, 5, 4}));
}

TEST(SweepGrouping, EqualCostsKeepVariantOrder) {
  const std::vector<VariantResult> results = {result(0, 5.0, 2.0, {0, 1, 2}), result(1, 5.0, 2.0, {0, -1, 2})};
  const auto s = group_solutions(results, GroupingOptions{});
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].first_variant, 0);
  EXPECT_EQ(s[1].first_variant, 1);
}

TEST(SweepGrouping, EachResultJoinsTheFirstMatchingSolutionInVariantOrder) {
  // Variant 2 lies within the distance tolerance of both earlier representatives: it joins the first.
  GroupingOptions options;
  options.action_tol = 1;
  options.distance_tol = 0.6;
  const std::vector<VariantResult> results = {result(0, 5.0, 2.0, {0, 1.0, 2}), result(1, 5.0, 2.0, {0, 2.0, 2}),
                                              result(2, 5.0, 2.0, {0, 1.5, 2})};
  std::vector<int> solution_of;
  const auto s = group_solutions(results, options, &solution_of);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(solution_of, (std::vector<int>{1, 2, 1}));
}

TEST(SweepGrouping, DistanceIsTheLargestComponentDifferenceAndInfiniteAcrossGrids) {
  const VariantResult a = result(0, 1, 1, {0, 1, 2, 3});
  const VariantResult b = result(1, 1, 1, {0, 1.25, 1.5, 3});
  const VariantResult c = result(2, 1, 1, {0, 1, 3});
  EXPECT_DOUBLE_EQ(trajectory_distance(a.trajectory, b.trajectory), 0.5);
  EXPECT_TRUE(std::isinf(trajectory_distance(a.trajectory, c.trajectory)));
  VariantResult d = a;
  d.trajectory.q[1] = std::nan("");
  d.id = 3;
  EXPECT_FALSE(same_solution(a, d, GroupingOptions{}));
}

TEST(SweepGrouping, CertificateVerdicts) {
  VariantResult r = result(0, 1, 1, {0, 1, 2});
  EXPECT_EQ(certificate_verdict(r), "minimum");
  r.hessian_positive_definite = false;
  r.inertia_negative = 12;
  EXPECT_EQ(certificate_verdict(r), "saddle (12 negative)");
  r.inertia_negative = 0;
  r.inertia_zero = 2;
  EXPECT_EQ(certificate_verdict(r), "degenerate (2 zero)");
  r.certificate_valid = false;
  EXPECT_EQ(certificate_verdict(r), "unknown");
}

TEST(SweepGrouping, SolutionsTableHasOneRowPerSolution) {
  std::vector<VariantResult> results = {result(0, 7.5, 2.0, {0, 1, 2}), result(1, 7.5, 2.0, {0, 1, 2}),
                                        result(2, 6.25, 1.5, {0, 0, 2})};
  results[2].hessian_positive_definite = false;
  results[2].inertia_negative = 3;
  const auto s = group_solutions(results, GroupingOptions{});
  EXPECT_EQ(solutions_csv(results, s),
            "solution,configuration,rank,cost,action,residual,variants,first_variant,certificate\n"
            "1,0,1,6.25,1.5,9.9999999999999998e-13,1,2,saddle (3 negative)\n"
            "2,0,2,7.5,2,9.9999999999999998e-13,2,0,minimum\n");
}

}  // namespace
