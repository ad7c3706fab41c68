// Tests of the `pardel` binary: `models`, `kernels` (JSON shape and values against calling the
// generated kernel directly), `solve` outputs and exit codes, and `check`.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "pardel/pardel.hpp"
#include "pardel/app/trajectory_io.hpp"

namespace {

using namespace pardel;
namespace fs = std::filesystem;

struct Result {
  int code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/** Runs the pardel binary with a shell-quoted argument string; captures stdout and stderr. */
Result pardel(const std::string& args) {
  static int counter = 0;
  const fs::path base = fs::temp_directory_path() / ("pardel_test_cli_" + std::to_string(::getpid()) + "_" +
                                                      std::to_string(counter++));
  const std::string command = std::string("'") + PARDEL_BINARY + "' " + args + " >'" + base.string() + ".out' 2>'" +
                              base.string() + ".err' </dev/null";
  const int status = std::system(command.c_str());
  Result r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(base.string() + ".out");
  r.err = slurp(base.string() + ".err");
  fs::remove(base.string() + ".out");
  fs::remove(base.string() + ".err");
  return r;
}

class TempDir {
 public:
  TempDir() : path_(fs::temp_directory_path() / ("pardel_test_solve_" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

// ---------------------------------------------------------------------------------------------
// models

TEST(PardelModels, ListsEveryBundledModel) {
  const Result r = pardel("models");
  ASSERT_EQ(r.code, 0) << r.err;
  for (const pardel_model* m : bundled_models()) EXPECT_NE(r.out.find(m->name), std::string::npos) << m->name;
}

TEST(PardelModels, JsonMatchesTheRegistry) {
  const Result r = pardel("models --json");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto list = nlohmann::json::parse(r.out);
  ASSERT_EQ(list.size(), bundled_models().size());
  for (std::size_t i = 0; i < list.size(); ++i) {
    const pardel_model& m = *bundled_models()[i];
    EXPECT_EQ(list[i]["name"], m.name);
    EXPECT_EQ(list[i]["order"], m.order);
    ASSERT_EQ(list[i]["coords"].size(), static_cast<std::size_t>(m.ncoords));
    EXPECT_EQ(list[i]["coords"][0], m.coords[0]);
    ASSERT_EQ(list[i]["params"].size(), static_cast<std::size_t>(m.nparams));
    for (int p = 0; p < m.nparams; ++p) EXPECT_EQ(list[i]["params"][m.param_names[p]], m.param_defaults[p]);
    ASSERT_EQ(list[i]["discretizations"].size(), static_cast<std::size_t>(m.ndiscretizations));
    EXPECT_EQ(list[i]["discretizations"][0]["name"], m.discretizations[0].name);
    EXPECT_EQ(list[i]["clock"], m.clock != nullptr);
  }
}

// ---------------------------------------------------------------------------------------------
// kernels

void expect_kernels_match(const std::string& model_name, const std::string& disc_name, double h, double t0,
                          double t1, const std::vector<double>& q0, const std::vector<double>& q1,
                          const std::vector<std::pair<int, double>>& param_overrides) {
  const pardel_model* model = find_model(model_name);
  ASSERT_NE(model, nullptr) << model_name;
  const pardel_discretization* disc = find_discretization(*model, disc_name);
  ASSERT_NE(disc, nullptr) << disc_name;
  std::vector<double> p(model->param_defaults, model->param_defaults + model->nparams);
  std::string args = "kernels --model " + model_name + " --disc '" + disc_name + "' --h " + app::format_double(h) +
                     " --t0 " + app::format_double(t0) + " --t1 " + app::format_double(t1);
  auto join = [](const std::vector<double>& v) {
    std::string s;
    for (double x : v) s += (s.empty() ? "" : ",") + app::format_double(x);
    return s;
  };
  args += " --q0=" + join(q0) + " --q1=" + join(q1);
  for (const auto& [index, value] : param_overrides) {
    p[index] = value;
    args += std::string(" --param ") + model->param_names[index] + "=" + app::format_double(value);
  }
  const Result r = pardel(args);
  ASSERT_EQ(r.code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const int m = model->dim;
  double Ld = 0;
  std::vector<double> D1(m), D2(m), D11(m * m), D12(m * m), D22(m * m);
  disc->full(h, t0, t1, q0.data(), q1.data(), p.data(), &Ld, D1.data(), D2.data(), D11.data(), D12.data(), D22.data());
  ASSERT_EQ(j.size(), 6u);
  // 17 significant digits round-trip doubles exactly: equality, not a tolerance.
  EXPECT_EQ(j["Ld"].get<double>(), Ld);
  ASSERT_EQ(j["D1"].size(), static_cast<std::size_t>(m));
  ASSERT_EQ(j["D22"].size(), static_cast<std::size_t>(m));
  for (int a = 0; a < m; ++a) {
    EXPECT_EQ(j["D1"][a].get<double>(), D1[a]);
    EXPECT_EQ(j["D2"][a].get<double>(), D2[a]);
    ASSERT_EQ(j["D12"][a].size(), static_cast<std::size_t>(m));
    for (int b = 0; b < m; ++b) {
      EXPECT_EQ(j["D11"][a][b].get<double>(), D11[a * m + b]) << a << "," << b;
      EXPECT_EQ(j["D12"][a][b].get<double>(), D12[a * m + b]) << a << "," << b;
      EXPECT_EQ(j["D22"][a][b].get<double>(), D22[a * m + b]) << a << "," << b;
    }
  }
}

TEST(PardelKernels, FuelNavTrapezoidEqualsTheKernel) {
  expect_kernels_match("fuel_nav", "trapezoid", 0.15, 0.3, 0.45, {0.1, -0.7}, {0.35, -0.2}, {});
}

TEST(PardelKernels, InterpFuelWithAParamEqualsTheKernel) {
  expect_kernels_match("interp_fuel", "trapezoid(alpha=1)", 0.25, 1.0, 1.25, {0.1, 0.2, -0.3, 0.4},
                       {0.2, 0.1, 0.5, -0.6}, {{0, 7.5}});
}

TEST(PardelKernels, BadOptionsNameTheOptionAndExitWith2) {
  const std::string base = " --h 0.1 --t0 0 --t1 0.1";
  struct Case {
    std::string args, fragment;
  };
  const std::vector<Case> cases = {
      {"kernels --model fule_nav --disc trapezoid" + base + " --q0=0,0 --q1=1,1",
       "--model: unknown model 'fule_nav'; did you mean 'fuel_nav'?"},
      {"kernels --model fuel_nav --disc trapezoidd" + base + " --q0=0,0 --q1=1,1",
       "--disc: unknown discretization 'trapezoidd' for model fuel_nav; did you mean 'trapezoid'?"},
      {"kernels --model fuel_nav --disc trapezoid" + base + " --q0=0,0,0 --q1=1,1",
       "--q0: 3 values given; expected 2"},
      {"kernels --model interp_fuel --disc gauss2" + base + " --q0=0,0 --q1=1,1,1,1", "--q0: 2 values given; expected 4"},
      {"kernels --model fuel_nav --disc trapezoid --h abc --t0 0 --t1 0.1 --q0=0,0 --q1=1,1",
       "--h: 'abc' is not a number"},
      {"kernels --model fuel_nav --disc trapezoid" + base + " --q0=0,x --q1=1,1", "--q0: 'x' is not a number"},
      {"kernels --model interp_fuel --disc gauss2" + base + " --q0=0,0,0,0 --q1=1,1,1,1 --param cc=3",
       "--param: model interp_fuel has no param 'cc'; did you mean 'c'?"},
      {"kernels --model interp_fuel --disc gauss2" + base + " --q0=0,0,0,0 --q1=1,1,1,1 --param c=three",
       "--param c: 'three' is not a number"},
      {"kernels --model interp_fuel --disc gauss2" + base + " --q0=0,0,0,0 --q1=1,1,1,1 --param c=2 --param c=3",
       "--param: 'c' is given twice"},
      {"kernels --model fuel_nav --disc trapezoid --q0=0,0 --q1=1,1", "--h"},
  };
  for (const auto& c : cases) {
    const Result r = pardel(c.args);
    EXPECT_EQ(r.code, 2) << c.args;
    EXPECT_NE(r.err.find(c.fragment), std::string::npos) << c.args << "\nstderr: " << r.err;
  }
}

TEST(PardelUsage, HelpSucceedsAndDocumentsExitCodes) {
  const Result r = pardel("solve --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("3 max_iterations"), std::string::npos) << r.out;
  EXPECT_EQ(pardel("").code, 2);
  EXPECT_EQ(pardel("frobnicate").code, 2);
}

// ---------------------------------------------------------------------------------------------
// solve and check

const char* const kSmallScene = R"TOML(model = "fuel_nav"
discretization = "trapezoid"
[grid]
T = 8
N = 40
[boundary]
q0 = [0, 0]
qN = [6, 5]
[solver]
method = "newton"
tol = 1e-10
)TOML";

TEST(PardelSolve, WritesEveryOutputAndExitsWith0WhenConverged) {
  TempDir dir;
  app::write_file_atomic(dir / "small.toml", kSmallScene);
  const Result r = pardel("solve '" + (dir / "small.toml") + "' --out '" + (dir / "out") + "' --quiet --no-plot");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;  // --quiet
  const auto summary = nlohmann::json::parse(slurp(dir / "out/summary.json"));
  EXPECT_EQ(summary["status"], "converged");
  EXPECT_LE(summary["residual"].get<double>(), 1e-10);
  EXPECT_EQ(summary["method"], "newton");
  EXPECT_EQ(summary["N"], 40);
  EXPECT_EQ(summary["model"], "fuel_nav");
  EXPECT_EQ(summary["discretization"], "trapezoid");
  EXPECT_EQ(summary["cost"]["name"], "fuel");
  EXPECT_EQ(summary["cost"]["value"], summary["action"]);
  for (const char* key : {"message", "iterations", "wall_seconds", "threads", "tolerance", "point"}) {
    EXPECT_TRUE(summary.contains(key)) << key;
  }
  // Every solve says what it found; the seed's certificate is computed only on request.
  EXPECT_EQ(summary["point"]["kind"], "minimum");
  EXPECT_EQ(summary["point"]["inertia"]["negative"], 0);
  EXPECT_EQ(summary["point"]["inertia"]["positive"], 2 * 39);
  EXPECT_GT(summary["point"]["lambda_min"].get<double>(), 0);
  EXPECT_FALSE(summary.contains("certificate"));
  const Result full = pardel("solve '" + (dir / "small.toml") + "' --out '" + (dir / "full") +
                             "' --quiet --no-plot --certificate full");
  ASSERT_EQ(full.code, 0) << full.err;
  const auto with_certificate = nlohmann::json::parse(slurp(dir / "full/summary.json"));
  EXPECT_TRUE(with_certificate["certificate"]["hessian_positive_definite"].get<bool>());
  EXPECT_EQ(with_certificate["certificate"]["inertia_positive"], summary["point"]["inertia"]["positive"]);
  // The trajectory file holds the solution: its residual, recomputed here, is below the tolerance.
  const Trajectory trajectory = app::read_trajectory_csv(dir / "out/trajectory.csv", *find_model("fuel_nav"));
  ASSERT_EQ(trajectory.N, 40);
  Problem problem;
  problem.model = find_model("fuel_nav");
  problem.discretization = find_discretization(*problem.model, "trapezoid");
  problem.T = 8;
  problem.N = 40;
  problem.q0 = {0, 0};
  problem.qN = {6, 5};
  EXPECT_LE(residual_norm(problem, trajectory), 1e-10);
  EXPECT_NEAR(discrete_action(problem, trajectory), summary["action"].get<double>(), 1e-12);
  const std::string convergence = slurp(dir / "out/convergence.csv");
  EXPECT_EQ(convergence.rfind("iteration,N,residual,action,seconds\n", 0), 0u);
  EXPECT_FALSE(fs::exists(dir / "out/trajectory.png"));  // --no-plot
  for (const auto& entry : fs::directory_iterator(dir / "out")) {
    EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
  }
}

TEST(PardelSolve, ExitCodeSaysHowItEnded) {
  TempDir dir;
  app::write_file_atomic(dir / "small.toml", kSmallScene);
  const Result r = pardel("solve '" + (dir / "small.toml") + "' --out '" + (dir / "out") +
                          "' --quiet --no-plot --set solver.method=jacobi-newton --set solver.max_iterations=3");
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(dir / "out/summary.json"))["status"], "max_iterations");
  const Result bad = pardel("solve '" + std::string(PARDEL_BAD_SCENES_DIR) + "/unknown_method.toml' --quiet --no-plot");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("unknown_method.toml:11:10: error: unknown method 'jacobi_newton'"), std::string::npos)
      << bad.err;
  const Result missing = pardel("solve '" + (dir / "absent.toml") + "' --quiet");
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.err.find("cannot open scene file"), std::string::npos) << missing.err;
  // A method pardel does not have (the multigrid of docs/benchmarks.md was measured and left out):
  // a usage error naming the key and the methods, and no outputs.
  const Result multigrid = pardel("solve '" + (dir / "small.toml") + "' --out '" + (dir / "mg") +
                                  "' --no-plot --set solver.method=multigrid");
  EXPECT_EQ(multigrid.code, 2);
  EXPECT_NE(multigrid.err.find("unknown method 'multigrid'"), std::string::npos) << multigrid.err;
  EXPECT_NE(multigrid.err.find("(methods: auto, jacobi, jacobi-newton, newton, hybrid, stationary-newton)"), std::string::npos)
      << multigrid.err;
  EXPECT_TRUE(multigrid.out.empty()) << multigrid.out;
  EXPECT_FALSE(fs::exists(dir / "mg"));
}

TEST(PardelSolve, ThreadsOptionFailsAsTheSceneKeyDoes) {
  // --threads of solve and sweep is held to solver.threads' bound and worded as a --set of that key.
  TempDir dir;
  app::write_file_atomic(dir / "small.toml", kSmallScene);
  app::write_file_atomic(dir / "sweep.toml", "scene = \"small.toml\"\n");
  const std::string rule = option_bound("threads")->rule;
  const Result set = pardel("solve '" + (dir / "small.toml") + "' --quiet --no-plot --set solver.threads=5000");
  EXPECT_EQ(set.code, 2);
  EXPECT_NE(set.err.find("--set solver.threads=5000: error: solver.threads " + rule + ", got 5000"), std::string::npos)
      << set.err;
  for (const std::string command : {"solve '" + (dir / "small.toml") + "'", "sweep '" + (dir / "sweep.toml") + "'"}) {
    for (const std::string value : {"5000", "-1", "99999999999999999999", "2.5", "abc"}) {
      const Result r = pardel(command + " --out '" + (dir / "out") + "' --quiet --no-plot --threads " + value);
      EXPECT_EQ(r.code, 2) << command;
      const bool integer = value.find_first_not_of("-0123456789") == std::string::npos;
      EXPECT_EQ(r.err, "--threads " + value + ": error: --threads " + (integer ? rule : "must be an integer") +
                           ", got " + value + "\n")
          << command;
      EXPECT_FALSE(fs::exists(dir / "out")) << command;
    }
  }
}

TEST(PardelSolve, DeviceOptionIsCheckedAndARefusedDeviceWritesNothing) {
  TempDir dir;
  app::write_file_atomic(dir / "small.toml", kSmallScene);
  const Result bad = pardel("solve '" + (dir / "small.toml") + "' --quiet --no-plot --device gpu");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--device: gpu not in {cpu,cuda}"), std::string::npos) << bad.err;
  // Hybrid does not run on the device; a build without CUDA or a machine without a device refuses
  // any method: either way the error names the device and nothing is written.
  const Result refused = pardel("solve '" + (dir / "small.toml") + "' --out '" + (dir / "out") +
                                "' --quiet --no-plot --device cuda --set solver.method=hybrid");
  EXPECT_EQ(refused.code, 2);
  EXPECT_NE(refused.err.find("error: device cuda: "), std::string::npos) << refused.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(PardelSolve, OpenMPThreadsWaitPassivelyUnlessTheUserChose) {
  // Spinning OpenMP threads cost a scheduler quantum per loop where another process holds a core
  // (docs/solvers.md): the command sets OMP_WAIT_POLICY=passive before OpenMP starts, and keeps
  // what the user set. The summary says which policy the solve ran with.
  TempDir dir;
  app::write_file_atomic(dir / "small.toml", kSmallScene);
  const std::string solve = "solve '" + (dir / "small.toml") + "' --out '" + (dir / "out") + "' --quiet --no-plot";
  const std::pair<const char*, const char*> cases[] = {{"env -u OMP_WAIT_POLICY -u GOMP_SPINCOUNT ", "passive"},
                                                       {"env -u GOMP_SPINCOUNT OMP_WAIT_POLICY=active ", "active"},
                                                       {"env -u OMP_WAIT_POLICY GOMP_SPINCOUNT=1000 ", "default"}};
  for (const auto& [environment, expected] : cases) {
    const std::string command = std::string(environment) + "'" + PARDEL_BINARY + "' " + solve + " 2>&1";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
    EXPECT_EQ(nlohmann::json::parse(slurp(dir / "out/summary.json"))["openmp_wait_policy"], expected) << command;
  }
}

TEST(PardelSolve, DrawsBothPlots) {
  TempDir dir;
  app::write_file_atomic(dir / "small.toml", kSmallScene);
  const Result r = pardel("solve '" + (dir / "small.toml") + "' --out '" + (dir / "out") + "' --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(r.err.find("warning") == std::string::npos) << r.err;
  for (const char* png : {"trajectory.png", "convergence.png"}) {
    const std::string bytes = slurp(dir / (std::string("out/") + png));
    ASSERT_GT(bytes.size(), 8u) << png;
    EXPECT_EQ(bytes.substr(1, 3), "PNG") << png;
  }
}

TEST(PardelSolve, PlotsASolveThatEndedNonFinite) {
  // summary.json writes the non-finite cost of such a solve as null: the plots are still drawn.
  TempDir dir;
  app::write_file_atomic(dir / "edge.lag", "model cli_edge\ncoords x\nL = 1/2*x'^2 + log(1 - x)\n"
                                             "discretizations trapezoid\n");
  app::write_file_atomic(dir / "edge.toml", "model = \"edge.lag\"\n[grid]\nT = 1\nN = 50\n[boundary]\nq0 = [0]\n"
                                              "qN = [3]\n[solver]\nmethod = \"jacobi-newton\"\n");
  const Result r = pardel("solve '" + (dir / "edge.toml") + "' --out '" + (dir / "out") + "' --quiet");
  EXPECT_EQ(r.code, 5) << r.err;  // non_finite
  EXPECT_EQ(r.err.find("plots not written"), std::string::npos) << r.err;
  EXPECT_TRUE(nlohmann::json::parse(slurp(dir / "out/summary.json"))["cost"]["value"].is_null());
  for (const char* png : {"trajectory.png", "convergence.png"}) {
    const std::string bytes = slurp(dir / (std::string("out/") + png));
    ASSERT_GT(bytes.size(), 8u) << png;
    EXPECT_EQ(bytes.substr(1, 3), "PNG") << png;
  }
}

TEST(PardelCheck, ReportsTheCertificateOfAGuessAndOfASolution) {
  TempDir dir;
  app::write_file_atomic(dir / "small.toml", kSmallScene);
  const Result guess = pardel("check '" + (dir / "small.toml") + "' --json");
  ASSERT_EQ(guess.code, 0) << guess.err;
  const auto at_guess = nlohmann::json::parse(guess.out);
  EXPECT_GT(at_guess["residual"].get<double>(), 1e-3);  // a straight line is not a solution
  ASSERT_EQ(pardel("solve '" + (dir / "small.toml") + "' --out '" + (dir / "out") + "' --quiet --no-plot").code, 0);
  const Result solved =
      pardel("check '" + (dir / "small.toml") + "' --trajectory '" + (dir / "out/trajectory.csv") + "' --json");
  ASSERT_EQ(solved.code, 0) << solved.err;
  const auto at_solution = nlohmann::json::parse(solved.out);
  EXPECT_LE(at_solution["residual"].get<double>(), 1e-10);
  EXPECT_TRUE(at_solution["certificate"].contains("theorem_holds"));
  const Result text = pardel("check '" + (dir / "small.toml") + "'");
  EXPECT_EQ(text.code, 0);
  EXPECT_NE(text.out.find("residual"), std::string::npos);
  const Result bad_csv = pardel("check '" + (dir / "small.toml") + "' --trajectory '" + (dir / "small.toml") + "'");
  EXPECT_EQ(bad_csv.code, 2);
  EXPECT_NE(bad_csv.err.find("--trajectory"), std::string::npos) << bad_csv.err;
}

}  // namespace
