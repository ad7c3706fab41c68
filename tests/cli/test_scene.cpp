// Tests of the scene parser (pardel/app/scene.hpp): the catalogue of bad scenes in
// tests/cli/bad_scenes (each names its expected location and message in its first two lines),
// a full valid scene, --set overrides, the solver options' bounds, suggestions and the initial guesses.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "pardel/app/scene.hpp"
#include "pardel/app/trajectory_io.hpp"

namespace {

using namespace pardel;
using namespace pardel::app;
namespace fs = std::filesystem;

const pardel_model* resolve(const std::string& name) { return find_model(name); }

Scene parse(const std::string& text, const std::vector<std::string>& sets = {}) {
  return parse_scene(text, "scene.toml", sets, resolve, bundled_model_names());
}

std::string error_of(const std::string& text, const std::vector<std::string>& sets = {}) {
  try {
    parse(text, sets);
  } catch (const SceneError& error) {
    return error.what();
  }
  return "(no error)";
}

const char* const kFuelNav = R"TOML(model = "fuel_nav"
[grid]
T = 30
N = 200
[boundary]
q0 = [0, 0]
qN = [6, 5]
)TOML";

// ---------------------------------------------------------------------------------------------
// The catalogue

std::vector<std::string> bad_scene_files() {
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(PARDEL_BAD_SCENES_DIR)) {
    if (entry.path().extension() == ".toml") files.push_back(entry.path().filename().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::string header_value(const std::string& path, const std::string& key) {
  std::ifstream in(path);
  std::string line;
  const std::string prefix = "# " + key + ":";
  while (std::getline(in, line)) {
    if (line.rfind(prefix, 0) == 0) {
      std::string value = line.substr(prefix.size());
      while (!value.empty() && value.front() == ' ') value.erase(value.begin());
      return value;
    }
  }
  ADD_FAILURE() << path << " has no '" << prefix << "' line";
  return "";
}

class BadScene : public ::testing::TestWithParam<std::string> {};

TEST_P(BadScene, GivesItsExpectedMessageAtItsLocation) {
  const std::string path = std::string(PARDEL_BAD_SCENES_DIR) + "/" + GetParam();
  const std::string location = header_value(path, "expect-location");
  const std::string message = header_value(path, "expect-message");
  std::string error = "(no error)";
  try {
    load_scene(path, {}, resolve, bundled_model_names());
  } catch (const SceneError& e) {
    error = e.what();
  }
  const std::string expected_start = location.empty() ? path + ": error: " : path + ":" + location + ": ";
  EXPECT_EQ(error.rfind(expected_start, 0), 0u) << "error: " << error << "\nexpected to start with: " << expected_start;
  EXPECT_NE(error.find(message), std::string::npos) << "error: " << error << "\nexpected to contain: " << message;
}

INSTANTIATE_TEST_SUITE_P(Catalogue, BadScene, ::testing::ValuesIn(bad_scene_files()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           std::string name = fs::path(info.param).stem().string();
                           std::replace_if(name.begin(), name.end(), [](char c) { return !std::isalnum(c); }, '_');
                           return name;
                         });

TEST(BadSceneCatalogue, HasAtLeastFifteenScenes) { EXPECT_GE(bad_scene_files().size(), 15u); }

// ---------------------------------------------------------------------------------------------
// Valid scenes

TEST(Scene, ReadsEveryKey) {
  const Scene scene = parse(R"TOML(model = "interp_fuel"
discretization = "trapezoid(alpha=1)"
[params]
c = 25
[grid]
t0 = 1
T = 60
N = 240
[boundary]
q0 = [0, 0]
v0 = [0.5, 0]
qN = [3, 5]
vN = [0, -1]
[[knots]]
t = 21
q = [1, 3]
[[knots]]
t = 41
q = [5, 2]
[guess]
kind = "polyline"
points = [[0, 0], [1, 3], [3, 5]]
[solver]
method = "newton"
tol = 1e-9
max_iterations = 500
damping = 0.25
newton_substeps = 2
newton_shift = "identity"
linear_solver = "cyclic-reduction"
device = "cuda"
threads = 1
refine = { start_N = 40, factor = 1.5, settle = 0.01 }
clock_update_every = 10
history_every = 5
divergence_factor = 1e6
clock = "none"
error_estimate = true
extrapolate = true
[output]
dir = "somewhere"
)TOML");
  ASSERT_NE(scene.model, nullptr);
  EXPECT_STREQ(scene.model->name, "interp_fuel");
  EXPECT_EQ(scene.discretization, "trapezoid(alpha=1)");
  ASSERT_EQ(scene.problem.params.size(), 1u);
  EXPECT_EQ(scene.problem.params[0], 25);
  EXPECT_EQ(scene.problem.t0, 1);
  EXPECT_EQ(scene.problem.T, 60);
  EXPECT_EQ(scene.problem.N, 240);
  EXPECT_EQ(scene.problem.q0, (std::vector<double>{0, 0, 0.5, 0}));
  EXPECT_EQ(scene.problem.qN, (std::vector<double>{3, 5, 0, -1}));
  ASSERT_EQ(scene.problem.knots.size(), 2u);
  EXPECT_EQ(scene.problem.knots[1].t, 41);
  EXPECT_EQ(scene.problem.knots[1].q, (std::vector<double>{5, 2}));
  EXPECT_EQ(scene.guess.kind, GuessKind::polyline);
  EXPECT_EQ(scene.guess.points.size(), 3u);
  EXPECT_EQ(scene.options.method, Method::newton);
  EXPECT_EQ(scene.options.tol, 1e-9);
  EXPECT_EQ(scene.options.max_iterations, 500);
  EXPECT_EQ(scene.options.damping, 0.25);
  EXPECT_EQ(scene.options.newton_substeps, 2);
  EXPECT_EQ(scene.options.newton_shift, NewtonShift::identity);
  EXPECT_EQ(scene.options.linear_solver, LinearSolver::cyclic_reduction);
  EXPECT_EQ(scene.options.device, Device::cuda);
  EXPECT_EQ(scene.options.threads, 1);
  EXPECT_EQ(scene.options.refine_start_N, 40);
  EXPECT_EQ(scene.options.refine_factor, 1.5);
  EXPECT_EQ(scene.options.clock_update_every, 10);
  EXPECT_EQ(scene.options.refine_settle, 0.01);
  EXPECT_EQ(scene.options.history_every, 5);
  EXPECT_EQ(scene.options.divergence_factor, 1e6);
  EXPECT_TRUE(scene.options.error_estimate);
  EXPECT_TRUE(scene.options.extrapolate);
  EXPECT_EQ(scene.problem.clock, ClockMode::none);
  EXPECT_EQ(scene.output_dir, "somewhere");
}

TEST(Scene, DefaultsWhenKeysAreLeftOut) {
  const Scene scene = parse(kFuelNav);
  EXPECT_EQ(scene.problem.t0, 0);
  EXPECT_STREQ(scene.problem.discretization->name, scene.model->discretizations[0].name);
  EXPECT_EQ(scene.guess.kind, GuessKind::linear);
  EXPECT_EQ(scene.options.method, Method::automatic);
  EXPECT_EQ(scene.options.tol, 0);  // no absolute tolerance: the relative one
  EXPECT_EQ(scene.options.rtol, 1e-10);
  EXPECT_EQ(scene.options.newton_shift, NewtonShift::difference);
  EXPECT_EQ(scene.options.linear_solver, LinearSolver::block_ldlt);
  EXPECT_EQ(scene.options.device, Device::cpu);
  EXPECT_TRUE(scene.options.error_estimate);
  EXPECT_FALSE(scene.options.extrapolate);
  EXPECT_TRUE(scene.output_dir.empty());
}

TEST(Scene, TrapezoidMeansAlphaOneForOrderTwoModels) {
  const Scene scene = parse(R"TOML(model = "interp_fuel"
discretization = "trapezoid"
[grid]
T = 60
N = 240
[boundary]
q0 = [0, 0]
v0 = [0, 0]
qN = [3, 5]
vN = [0, 0]
)TOML");
  EXPECT_EQ(scene.discretization, "trapezoid(alpha=1)");
}

TEST(Scene, ClockModesNeedAModelClock) {
  const std::string zermelo_tv = R"TOML(model = "zermelo_tv"
[grid]
T = 1
N = 50
[boundary]
q0 = [1, 6]
qN = [6, 2]
[solver]
clock = "free_final_time"
)TOML";
  if (!find_model("zermelo_tv")) GTEST_SKIP() << "zermelo_tv is not bundled in this build";
  EXPECT_EQ(parse(zermelo_tv).problem.clock, ClockMode::free_final_time);
}

TEST(Scene, AKnotOnTheGridIsSnappedToItsNodeTime) {
  // 0.3 and the node time t0 + 3h = 3 * 0.1 differ in the last bit: the knot takes the node time.
  const Scene scene = parse(R"TOML(model = "fuel_nav"
[grid]
T = 1
N = 10
[boundary]
q0 = [0, 0]
qN = [6, 5]
[[knots]]
t = 0.3
q = [1, 1]
)TOML");
  ASSERT_EQ(scene.problem.knots.size(), 1u);
  EXPECT_EQ(scene.problem.knots[0].t, 3 * (1.0 / 10));
}

// ---------------------------------------------------------------------------------------------
// --set overrides

TEST(SceneOverrides, ReplaceKeysWithTheSameChecks) {
  const Scene scene = parse(kFuelNav, {"solver.method=newton", "grid.N=50", "grid.T=8.5", "boundary.qN=[1,2]"});
  EXPECT_EQ(scene.options.method, Method::newton);
  EXPECT_EQ(scene.problem.N, 50);
  EXPECT_EQ(scene.problem.T, 8.5);
  EXPECT_EQ(scene.problem.qN, (std::vector<double>{1, 2}));
}

TEST(SceneOverrides, CreateTablesThatTheSceneLacks) {
  const Scene scene = parse(kFuelNav, {"solver.refine.start_N=20", "output.dir=elsewhere"});
  EXPECT_EQ(scene.options.refine_start_N, 20);
  EXPECT_EQ(scene.output_dir, "elsewhere");
}

TEST(SceneOverrides, ErrorsNameTheOverride) {
  EXPECT_EQ(error_of(kFuelNav, {"solver.metod=newton"}),
            "--set solver.metod=newton: error: unknown key 'solver.metod'; did you mean 'solver.method'?");
  EXPECT_EQ(error_of(kFuelNav, {"grid.N=abc"}),
            "--set grid.N=abc: error: grid.N must be an integer, got a string \"abc\"");
  EXPECT_EQ(error_of(kFuelNav, {"solver.method=jacobi-newtn"}).rfind("--set solver.method=jacobi-newtn: error: unknown "
                                                                     "method 'jacobi-newtn'; did you mean "
                                                                     "'jacobi-newton'?",
                                                                     0),
            0u);
  EXPECT_EQ(error_of(kFuelNav, {"solver.device=gpu"}),
            "--set solver.device=gpu: error: unknown device 'gpu' (expected 'cpu' or 'cuda')");
  EXPECT_NE(error_of(kFuelNav, {"grid.N"}).find("expected KEY=VALUE"), std::string::npos);
  EXPECT_NE(error_of(kFuelNav, {"grid..N=3"}).find("is not a key path"), std::string::npos);
  EXPECT_NE(error_of(kFuelNav, {"model.x=3"}).find("model is a string, not a table"), std::string::npos);
}

// ---------------------------------------------------------------------------------------------
// Solver options: the bounds of pardel::Options (option_bound), at the key's location

TEST(SceneSolverBounds, AreTheOptionsBoundsWithTheirRuleAndLocation) {
  const std::string scene = std::string(kFuelNav) + "[solver]\nnewton_substeps = 1001\n";
  EXPECT_EQ(error_of(scene), std::string("scene.toml:9:19: error: solver.newton_substeps ") +
                                 option_bound("newton_substeps")->rule + ", got 1001");
  EXPECT_EQ(error_of(kFuelNav, {"solver.refine.start_N=20", "solver.refine.factor=17"}),
            "--set solver.refine.factor=17: error: solver.refine.factor must be in (1, 16], got 17");
  EXPECT_EQ(error_of(kFuelNav, {"solver.refine.start_N=1"}),
            "--set solver.refine.start_N=1: error: solver.refine.start_N must be 0 (off; auto keeps its own levels) "
            "or >= 2, got 1");
  // The values the bounds admit at their ends: tol = 0 is the relative test, max_iterations = 0
  // evaluates the start, start_N = 0 turns a scene's refinement off.
  const Scene edges = parse(std::string(kFuelNav) + "[solver]\ntol = 1e-8\nrefine = { start_N = 20 }\n",
                            {"solver.tol=0", "solver.max_iterations=0", "solver.refine.start_N=0",
                             "solver.newton_substeps=1000", "solver.threads=4096", "solver.refine.factor=16"});
  EXPECT_EQ(edges.options.tol, 0);
  EXPECT_EQ(edges.options.max_iterations, 0);
  EXPECT_EQ(edges.options.refine_start_N, 0);
  EXPECT_EQ(edges.options.newton_substeps, 1000);
  EXPECT_EQ(edges.options.threads, 4096);
  EXPECT_EQ(edges.options.refine_factor, 16);
}

// ---------------------------------------------------------------------------------------------
// Suggestions and guesses

TEST(Suggestions, EditDistanceAndNearestName) {
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
  EXPECT_EQ(edit_distance("", "abc"), 3u);
  EXPECT_EQ(edit_distance("same", "same"), 0u);
  EXPECT_EQ(nearest_name("metod", {"method", "tol", "damping"}), "method");
  EXPECT_EQ(nearest_name("zzzzzz", {"method", "tol", "damping"}), "");
}

TEST(Guess, LinearGuessJoinsTheBoundary) {
  const Scene scene = parse(kFuelNav);
  const Trajectory guess = make_initial_guess(scene);
  ASSERT_EQ(guess.N, 200);
  EXPECT_EQ(guess.node(0)[0], 0);
  EXPECT_EQ(guess.node(200)[1], 5);
  EXPECT_NEAR(guess.node(100)[0], 3, 1e-12);
  EXPECT_NEAR(guess.node(100)[1], 2.5, 1e-12);
}

TEST(Guess, CsvGuessIsReadAndResampled) {
  const Scene coarse = parse(kFuelNav, {"grid.N=20"});
  const Trajectory line = make_initial_guess(coarse);
  const fs::path dir = fs::temp_directory_path() / ("pardel_test_guess_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string csv = (dir / "guess.csv").string();
  write_file_atomic(csv, trajectory_csv(*coarse.model, line));
  const std::string scene_path = (dir / "scene.toml").string();
  write_file_atomic(scene_path, std::string(kFuelNav) + "[guess]\nkind = \"csv\"\npath = \"guess.csv\"\n");
  const Scene scene = load_scene(scene_path, {"grid.N=40"}, resolve, bundled_model_names());
  EXPECT_EQ(scene.guess.csv_path, csv);
  const Trajectory guess = make_initial_guess(scene);
  ASSERT_EQ(guess.N, 40);
  for (int k = 0; k <= 40; ++k) {
    EXPECT_NEAR(guess.node(k)[0], 6.0 * k / 40, 1e-9) << "k = " << k;
    EXPECT_NEAR(guess.node(k)[1], 5.0 * k / 40, 1e-9) << "k = " << k;
  }
  fs::remove_all(dir);
}

}  // namespace
