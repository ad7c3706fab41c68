// Tests of the solve outputs (pardel/app/outputs.hpp): convergence.csv, the
// certificate's JSON, the physical cost (the summed clock checked against path length) and the
// boundary momenta of summary.json (checked against the harmonic oscillator's exact velocities) and
// its error estimate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "pardel/app/outputs.hpp"
#include "pardel/app/trajectory_io.hpp"

namespace {

using namespace pardel;
using namespace pardel::app;

TEST(Outputs, ConvergenceCsvHasOneRowPerRecord) {
  Summary summary;
  for (int i = 0; i < 3; ++i) {
    IterationRecord r;
    r.iteration = i;
    r.N = 10;
    r.residual = std::pow(10.0, -i);
    r.action = 2.5;
    r.seconds = 0.125 * i;
    summary.history.push_back(r);
  }
  EXPECT_EQ(convergence_csv(summary),
            "iteration,N,residual,action,seconds\n0,10,1,2.5,0\n1,10,0.10000000000000001,2.5,0.125\n"
            "2,10,0.01,2.5,0.25\n");
}

TEST(Outputs, CertificateJsonHasEveryFieldAndCapsViolations) {
  Certificate c;
  c.theorem_holds = false;
  c.inertia_positive = 7;
  c.inertia_negative = 1;
  c.jacobi_spectral_radius = 0.99;
  for (int k = 0; k < 5; ++k) {
    IntervalViolation v;
    v.k = k;
    v.hessian_psd = false;
    v.min_eig_hessian = -k;
    c.violations.push_back(v);
  }
  c.intervals_violating = 5;
  c.free_components = 12;
  const auto j = certificate_json(c, 3);
  for (const char* key : {"theorem_holds", "all_intervals_psd", "all_A_pd", "all_B_pd", "hessian_positive_definite",
                          "inertia_positive", "inertia_negative", "inertia_zero", "jacobi_spectral_radius",
                          "jacobi_one_minus_rho", "jacobi_one_minus_rho_roundoff", "spectral_radius_resolved",
                          "spectral_radius_converged", "expected_iterations", "violations_total", "violations",
                          "free_components", "intervals_violating", "residual", "tol", "error"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["violations_total"], 5);
  EXPECT_EQ(j["free_components"], 12);
  ASSERT_EQ(j["violations"].size(), 3u);
  EXPECT_EQ(j["violations"][2]["k"], 2);
  EXPECT_EQ(j["violations"][2]["min_eig_hessian"], -2.0);
  EXPECT_EQ(j["inertia_negative"], 1);
}

Scene scene_for(const char* model_name) {
  Scene scene;
  scene.model = find_model(model_name);
  scene.problem.model = scene.model;
  if (scene.model) {
    scene.problem.discretization = &scene.model->discretizations[0];
    scene.problem.params.assign(scene.model->param_defaults, scene.model->param_defaults + scene.model->nparams);
  }
  return scene;
}

TEST(Outputs, FuelIsTheActionForFuelNav) {
  const Scene scene = scene_for("fuel_nav");
  ASSERT_NE(scene.model, nullptr);
  Summary summary;
  summary.action = 5.25;
  const PhysicalCost cost = physical_cost(scene, summary, Trajectory{});
  EXPECT_EQ(cost.name, "fuel");
  EXPECT_EQ(cost.value, 5.25);
}

TEST(Outputs, TravelTimeInStillAirIsThePathLength) {
  // With the wind scale s = 0, Zermelo's F is the Euclidean speed, so the summed clock of any
  // polyline is its length, whatever the step.
  Scene scene = scene_for("zermelo");
  ASSERT_NE(scene.model, nullptr);
  ASSERT_NE(scene.model->clock, nullptr);
  ASSERT_EQ(scene.model->nparams, 1);
  scene.problem.params[0] = 0;
  scene.problem.T = 2;
  Trajectory path;
  path.N = 3;
  path.dim = 2;
  path.t = {0, 2.0 / 3, 4.0 / 3, 2};
  path.q = {0, 0, 3, 4, 3, 5, 6, 9};  // legs of length 5, 1, 5
  scene.problem.N = 3;
  Summary summary;
  const PhysicalCost cost = physical_cost(scene, summary, path);
  EXPECT_EQ(cost.name, "travel_time");
  EXPECT_NEAR(cost.value, 11.0, 1e-12);
}

TEST(Outputs, CostFollowsTheModelsDeclarationNotItsName) {
  // The same zermelo kernels without the .lag's `cost travel_time = clock`: the discrete action,
  // under its own name; the harmonic kernels declaring `cost energy = action`: the action as energy.
  Scene scene = scene_for("zermelo");
  ASSERT_NE(scene.model, nullptr);
  pardel_model undeclared = *scene.model;
  undeclared.cost_name = nullptr;
  scene.model = &undeclared;
  scene.problem.model = &undeclared;
  Summary summary;
  summary.action = 1.5;
  PhysicalCost cost = physical_cost(scene, summary, Trajectory{});
  EXPECT_EQ(cost.name, "action");
  EXPECT_EQ(cost.value, 1.5);

  Scene harmonic = scene_for("harmonic");
  ASSERT_NE(harmonic.model, nullptr);
  pardel_model declared = *harmonic.model;
  declared.cost_name = "energy";
  declared.cost_kind = PARDEL_COST_ACTION;
  harmonic.model = &declared;
  harmonic.problem.model = &declared;
  cost = physical_cost(harmonic, summary, Trajectory{});
  EXPECT_EQ(cost.name, "energy");
  EXPECT_EQ(cost.value, 1.5);
}

TEST(Outputs, SummaryHasTheBoundaryMomentaOfTheSolvedOscillator) {
  // x'' = -x, x(0) = 0, x(T) = 1: x = sin t / sin T, so x'(0) = 1 / sin T and x'(T) = cos T / sin T;
  // the discrete momenta approach them at second order (trapezoid, N = 200: within 1e-4).
  Scene scene = scene_for("harmonic");
  ASSERT_NE(scene.model, nullptr);
  const double T = 1.3;
  scene.problem.T = T;
  scene.problem.N = 200;
  scene.problem.q0 = {0};
  scene.problem.qN = {1};
  Trajectory trajectory = linear_guess(scene.problem);
  Options options;
  options.method = Method::newton;
  const Summary summary = solve(scene.problem, options, trajectory);
  ASSERT_TRUE(summary.converged()) << summary.message;
  const nlohmann::ordered_json j = summary_json(scene, summary, trajectory, Certificate{}, "");
  ASSERT_TRUE(j.contains("boundary_momenta"));
  const auto& momenta = j["boundary_momenta"];
  ASSERT_EQ(momenta["p0"].size(), 1u);
  ASSERT_EQ(momenta["pN"].size(), 1u);
  EXPECT_NEAR(momenta["p0"][0].get<double>(), 1 / std::sin(T), 1e-4);
  EXPECT_NEAR(momenta["pN"][0].get<double>(), std::cos(T) / std::sin(T), 1e-4);
  const BoundaryMomenta exact = boundary_momenta(scene.problem, trajectory);
  EXPECT_EQ(momenta["p0"][0].get<double>(), exact.p0[0]);
  EXPECT_EQ(momenta["pN"][0].get<double>(), exact.pN[0]);
}

TEST(Outputs, SummaryBoundaryMomentaAreNullWithoutATrajectory) {
  const Scene scene = scene_for("harmonic");
  ASSERT_NE(scene.model, nullptr);
  const nlohmann::ordered_json j = summary_json(scene, Summary{}, Trajectory{}, Certificate{}, "");
  EXPECT_TRUE(j["boundary_momenta"].is_null());
}

TEST(Outputs, SummaryHasTheErrorEstimateOrNullWithItsReason) {
  // x'' = -x from 0 to 1 over T = 1.3: the estimate, by coordinate name, is close to the largest
  // node error against x = sin t / sin T; a summary without one has null and the reason.
  Scene scene = scene_for("harmonic");
  ASSERT_NE(scene.model, nullptr);
  const double T = 1.3;
  scene.problem.T = T;
  scene.problem.N = 40;
  scene.problem.q0 = {0};
  scene.problem.qN = {1};
  Trajectory trajectory = linear_guess(scene.problem);
  const Summary summary = solve(scene.problem, Options{}, trajectory);
  ASSERT_TRUE(summary.converged()) << summary.message;
  double truth = 0;
  for (int k = 0; k <= 40; ++k)
    truth = std::max(truth, std::fabs(trajectory.node(k)[0] - std::sin(trajectory.t[k]) / std::sin(T)));
  const nlohmann::ordered_json j = summary_json(scene, summary, trajectory, Certificate{}, "");
  const double estimate = j["error_estimate"].get<double>();
  EXPECT_GT(estimate, truth / 3);
  EXPECT_LT(estimate, truth * 3);
  EXPECT_EQ(j["error"]["by_coordinate"]["x"].get<double>(), estimate);
  EXPECT_EQ(j["error"]["coarse_N"].get<int>(), 20);
  EXPECT_FALSE(j["error"]["extrapolated"].get<bool>());
  // The check over a third grid level (N = 10) observes the order 2 of the discretization.
  EXPECT_NEAR(j["error"]["observed_order"].get<double>(), 2, 0.2);
  EXPECT_EQ(j["error"]["observed_order"].get<double>(), summary.error_observed_order);
  EXPECT_TRUE(j["error"]["reliable"].get<bool>());
  EXPECT_EQ(j["error"]["note"].get<std::string>(), summary.error_note);
  // An order-1 model: the automatic iterative refinement does not run, and says nothing.
  EXPECT_EQ(j["refinement"]["steps"].get<int>(), 0);
  EXPECT_EQ(j["refinement"]["note"].get<std::string>(), "");

  Summary not_converged;
  not_converged.termination = Termination::max_iterations;
  not_converged.error_note = "not estimated: the solve ended max_iterations";
  const nlohmann::ordered_json n = summary_json(scene, not_converged, trajectory, Certificate{}, "");
  EXPECT_TRUE(n["error_estimate"].is_null());
  EXPECT_TRUE(n["error"]["by_coordinate"].empty());
  EXPECT_EQ(n["error"]["coarse_N"].get<int>(), 0);
  EXPECT_TRUE(n["error"]["observed_order"].is_null());
  EXPECT_FALSE(n["error"]["reliable"].get<bool>());
  EXPECT_EQ(n["error"]["note"].get<std::string>(), "not estimated: the solve ended max_iterations");
}

TEST(Outputs, DiskRefusalComparesTrajectoryCsvWithTheFreeSpace) {
  // zermelo: k, t, x, y and two velocity columns; 16 bytes a value, (N + 1) rows.
  Scene scene = scene_for("zermelo");
  scene.problem.N = 999;
  const double columns = static_cast<double>(pardel::app::state_column_names(*scene.model).size() + 2);
  const double need = 16.0 * 1000 * columns;
  EXPECT_EQ(pardel::app::disk_refusal(scene, "out/z", need), "");
  const std::string refused = pardel::app::disk_refusal(scene, "out/z", need - 1);
  EXPECT_NE(refused.find("out/z: trajectory.csv alone needs about"), std::string::npos) << refused;
  EXPECT_NE(refused.find("(1000 rows of"), std::string::npos) << refused;
  EXPECT_NE(refused.find("lower grid.N"), std::string::npos) << refused;
  // On this machine's file system a scene of this size fits (a folder not yet made is checked on
  // its first existing ancestor).
  EXPECT_EQ(pardel::app::disk_refusal(scene, ::testing::TempDir() + "/not/yet/made"), "");
}

}  // namespace
