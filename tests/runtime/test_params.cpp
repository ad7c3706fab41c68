/**
 * @file test_params.cpp
 * Params by name (pardel::find_param, pardel::params_by_name): names map to the model's declaration
 * order, unnamed params keep their defaults, an unknown name is refused with a message naming it and
 * the model's params, and a problem set up by name solves like one set up by position.
 */
#include <gtest/gtest.h>

#include <cmath>

#include "hand_models.hpp"
#include "pardel/pardel.hpp"

namespace {

// Two params, for the order of declaration; no kernels are needed by the functions under test.
const char* const two_coords[] = {"x"};
const char* const two_params[] = {"a", "b"};
const double two_defaults[] = {1.5, -2.0};
const pardel_model two = {PARDEL_KERNEL_ABI_VERSION, "two", "test_params.cpp", 1, 1, 1, two_coords, 2, two_params,
                          two_defaults, 0, nullptr, 0, nullptr, nullptr, PARDEL_COST_ACTION};
const pardel_model none = {PARDEL_KERNEL_ABI_VERSION, "none", "test_params.cpp", 1, 1, 1, two_coords, 0, nullptr,
                           nullptr, 0, nullptr, 0, nullptr, nullptr, PARDEL_COST_ACTION};

TEST(Params, FindParamGivesTheDeclarationIndex) {
  EXPECT_EQ(pardel::find_param(two, "a"), 0);
  EXPECT_EQ(pardel::find_param(two, "b"), 1);
  EXPECT_EQ(pardel::find_param(two, "c"), -1);
  EXPECT_EQ(pardel::find_param(none, "a"), -1);
}

TEST(Params, NamedValuesReplaceTheDefaults) {
  std::vector<double> params;
  ASSERT_TRUE(pardel::params_by_name(two, {{"b", 7.0}}, &params));
  EXPECT_EQ(params, (std::vector<double>{1.5, 7.0}));
  ASSERT_TRUE(pardel::params_by_name(two, {}, &params));
  EXPECT_EQ(params, (std::vector<double>{1.5, -2.0}));
  ASSERT_TRUE(pardel::params_by_name(none, {}, &params));
  EXPECT_TRUE(params.empty());
}

TEST(Params, AnUnknownNameIsRefusedAndNamed) {
  std::vector<double> params = {42.0};
  std::string error;
  EXPECT_FALSE(pardel::params_by_name(two, {{"a", 1.0}, {"omega", 3.0}}, &params, &error));
  EXPECT_EQ(error, "model two has no param 'omega' (its params: a, b)");
  EXPECT_EQ(params, std::vector<double>{42.0});
  EXPECT_FALSE(pardel::params_by_name(none, {{"a", 1.0}}, &params, &error));
  EXPECT_EQ(error, "model none has no param 'a' (its params: none)");
}

TEST(Params, ByNameSolvesLikeByPosition) {
  pardel::Problem problem;
  problem.model = &hand::harmonic;
  problem.discretization = &hand::harmonic.discretizations[0];
  problem.T = 1.3;
  problem.N = 40;
  problem.q0 = {0};
  problem.qN = {1};
  ASSERT_TRUE(pardel::params_by_name(hand::harmonic, {{"omega", 2.0}}, &problem.params));
  EXPECT_EQ(problem.params, std::vector<double>{2.0});
  pardel::Trajectory by_name = pardel::linear_guess(problem);
  pardel::Options options;
  options.method = pardel::Method::newton;
  ASSERT_TRUE(pardel::solve(problem, options, by_name).converged());
  // x(t) = sin(2t) / sin(2T): the discrete answer is within the trapezoid's O(h^2) of it.
  const double h = problem.T / problem.N;
  for (int k = 0; k <= problem.N; ++k)
    EXPECT_NEAR(by_name.node(k)[0], std::sin(2.0 * k * h) / std::sin(2.0 * problem.T), 1e-2);

  problem.params = {2.0};
  pardel::Trajectory by_position = pardel::linear_guess(problem);
  ASSERT_TRUE(pardel::solve(problem, options, by_position).converged());
  EXPECT_EQ(by_name.q, by_position.q);
}

}  // namespace
