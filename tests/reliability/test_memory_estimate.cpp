// The memory estimate of `pardel solve`: compared with the peak resident set size of real solves
// (getrusage of the child) for several N and methods, and the refusals it makes possible — a scene
// too large for the address space (a child under setrlimit(RLIMIT_AS)) or for the machine is
// refused with exit status 2 and a message naming grid.N, before anything is allocated or
// written; a std::bad_alloc that happens anyway becomes a message, not a crash.
#include <gtest/gtest.h>

#include <algorithm>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "pardel/memory.hpp"
#include "pardel/pardel.hpp"
#include "pardel/app/scene.hpp"

namespace {

namespace fs = std::filesystem;

struct Outcome {
  int status = -1;          ///< exit status, or 128 + signal
  double peak_bytes = 0;    ///< the child's maximum resident set size
  std::string output;       ///< stdout and stderr
};

/** Runs pardel with `args` in a child, with RLIMIT_AS = address_limit when > 0. */
Outcome run_pardel(const std::vector<std::string>& args, const fs::path& log, double address_limit = 0) {
  Outcome o;
  std::fflush(stdout);  // or the child would print what this process has buffered
  const pid_t pid = ::fork();
  if (pid == 0) {
    if (address_limit > 0) {
      const rlimit limit{static_cast<rlim_t>(address_limit), static_cast<rlim_t>(address_limit)};
      if (::setrlimit(RLIMIT_AS, &limit) != 0) ::_exit(126);
    }
    std::FILE* f = std::freopen(log.c_str(), "w", stdout);
    if (!f || ::dup2(::fileno(stdout), STDERR_FILENO) < 0) ::_exit(126);
    std::vector<char*> argv{const_cast<char*>(PARDEL_CLI_PATH)};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(PARDEL_CLI_PATH, argv.data());
    ::_exit(127);
  }
  int wstatus = 0;
  rusage usage{};
  if (pid < 0 || ::wait4(pid, &wstatus, 0, &usage) != pid) return o;
  o.status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
  o.peak_bytes = static_cast<double>(usage.ru_maxrss) * 1024;
  std::ifstream in(log);
  std::ostringstream s;
  s << in.rdbuf();
  o.output = s.str();
  return o;
}

class MemoryEstimate : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("pardel_memory_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    scene_ = dir_ / "fuel.toml";
    std::ofstream(scene_) << "model = \"fuel_nav\"\ndiscretization = \"trapezoid\"\n[grid]\nt0 = 0\nT = 30\nN = 200\n"
                             "[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n[guess]\nkind = \"linear\"\n"
                             "[solver]\nmethod = \"jacobi-newton\"\ntol = 1e-10\n";
    // A convex action (a free particle from a bent guess): every iterate is a minimum, so the
    // point assessment takes its largest path (the eigenvalue iteration after the factorization).
    convex_ = dir_ / "convex.toml";
    std::ofstream(convex_) << "model = \"free_particle\"\ndiscretization = \"trapezoid\"\n[grid]\nt0 = 0\nT = 1\n"
                              "N = 200\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n[guess]\nkind = \"polyline\"\n"
                              "points = [[0, 0], [5, -3], [6, 5]]\n[solver]\nmethod = \"jacobi-newton\"\ntol = 1e-10\n";
    use_ = scene_;
  }
  void TearDown() override { fs::remove_all(dir_); }

  pardel::app::Scene scene(const std::vector<std::string>& sets) const {
    return pardel::app::load_scene(use_.string(), sets, [](const std::string& n) { return pardel::find_model(n); });
  }

  /** Peak RSS of a two-iteration solve at N minus that of a tiny solve, against the estimate; with
   *  `certificate`, `pardel solve --certificate full`; with `to_convergence`, a whole solve. */
  double measured_over_estimated(const std::string& method, int N, bool certificate = false,
                                 bool to_convergence = false) {
    std::vector<std::string> sets = {"grid.N=" + std::to_string(N), "solver.method=" + method};
    if (!to_convergence) sets.push_back("solver.max_iterations=2");
    auto args = [&](int n) {
      std::vector<std::string> a = {"solve", use_.string(), "--out", (dir_ / "out").string(), "--threads", "1",
                                    "--no-plot", "--quiet"};
      for (const auto& s : sets) a.insert(a.end(), {"--set", s});
      if (certificate) a.insert(a.end(), {"--certificate", "full"});
      a.insert(a.end(), {"--set", "grid.N=" + std::to_string(n)});
      return a;
    };
    const Outcome base = run_pardel(args(100), dir_ / "base.log");
    const Outcome big = run_pardel(args(N), dir_ / "big.log");
    EXPECT_EQ(base.status, to_convergence ? 0 : 3) << base.output;
    EXPECT_EQ(big.status, to_convergence ? 0 : 3) << big.output;
    const pardel::app::Scene at = scene(sets);
    // A solve stopped by max_iterations is not assessed (only a converged point is): its peak is
    // the estimate's other parts.
    const pardel::MemoryEstimate e = pardel::estimate_solve_memory(at.problem, at.options, certificate);
    const double estimate = to_convergence ? e.peak : std::max({e.solve, e.certificate, e.output});
    const double ratio = (big.peak_bytes - base.peak_bytes) / estimate;
    std::printf("method %s%s, N = %d: estimate %.1f MB, measured %.1f MB above a small solve (%.1f MB): ratio %.3f\n",
                method.c_str(), certificate ? " with the certificate" : "", N, estimate / 1e6, (big.peak_bytes - base.peak_bytes) / 1e6, base.peak_bytes / 1e6,
                ratio);
    return ratio;
  }

  fs::path dir_, scene_, convex_;
  fs::path use_;  ///< the scene measured_over_estimated() solves
};

// The estimate must neither miss memory (ratio above 1.25) nor refuse solves that fit by a wide
// margin (ratio below 0.75).
TEST_F(MemoryEstimate, AgreesWithMeasuredPeakOfAConvergedSolve) {
  // Only a converged solve is assessed: Newton solves the convex action in a few iterations (to
  // the default relative tolerance: 1e-10 absolute is below the round-off level at these N), and
  // the peak is then the assessment's.
  use_ = dir_ / "convex_relative.toml";
  std::ofstream(use_) << "model = \"free_particle\"\ndiscretization = \"trapezoid\"\n[grid]\nt0 = 0\nT = 1\n"
                         "N = 200\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n[guess]\nkind = \"polyline\"\n"
                         "points = [[0, 0], [5, -3], [6, 5]]\n";
  for (int N : {50000, 150000}) {
    const double ratio = measured_over_estimated("newton", N, false, true);
    EXPECT_GT(ratio, 0.75) << "N = " << N;
    EXPECT_LT(ratio, 1.25) << "N = " << N;
  }
}

TEST_F(MemoryEstimate, AgreesWithMeasuredPeakWithTheCertificate) {
  use_ = convex_;
  const double ratio = measured_over_estimated("jacobi-newton", 100000, true);
  EXPECT_GT(ratio, 0.75);
  EXPECT_LT(ratio, 1.25);
}

// Auto solves coarse levels first; its peak is on the finest, reached only by a whole solve.
TEST_F(MemoryEstimate, AgreesWithMeasuredPeakForAuto) {
  const double ratio = measured_over_estimated("auto", 60000, false, true);
  EXPECT_GT(ratio, 0.75);
  EXPECT_LT(ratio, 1.25);
}

TEST_F(MemoryEstimate, AgreesWithMeasuredPeakForNewtonAndHybrid) {
  for (const char* method : {"newton", "hybrid"}) {
    const double ratio = measured_over_estimated(method, 60000);
    EXPECT_GT(ratio, 0.75) << method;
    EXPECT_LT(ratio, 1.25) << method;
  }
}

// Newton's trial evaluation keeps a second set of interval arrays from the first refused step of a
// level on, which the estimate leaves out (the finest level of a nested solve seldom takes it): a
// single-level Newton solve of the fuel example refuses steps within its first ten iterations.
TEST_F(MemoryEstimate, AgreesWithMeasuredPeakOfNewtonAfterRefusedSteps) {
  const auto refusing = [&](int iterations) {
    const std::string out = (dir_ / ("refusing" + std::to_string(iterations))).string();
    const std::vector<std::string> args = {"solve", scene_.string(), "--out", out, "--threads", "1", "--no-plot",
                                           "--quiet", "--set", "solver.method=newton", "--set", "grid.N=60000",
                                           "--set", "solver.max_iterations=" + std::to_string(iterations)};
    return run_pardel(args, dir_ / "refusing.log");
  };
  const Outcome base = run_pardel({"solve", scene_.string(), "--out", (dir_ / "base").string(), "--threads", "1",
                                   "--no-plot", "--quiet", "--set", "solver.method=newton", "--set",
                                   "solver.max_iterations=2", "--set", "grid.N=100"},
                                  dir_ / "base.log");
  const Outcome two = refusing(2), ten = refusing(10);
  ASSERT_EQ(two.status, 3) << two.output;
  ASSERT_EQ(ten.status, 3) << ten.output;
  // The second set: a fifth or more of the solve's memory once a step was refused.
  EXPECT_GT(ten.peak_bytes - base.peak_bytes, 1.2 * (two.peak_bytes - base.peak_bytes));
  const auto s = scene({"grid.N=60000", "solver.method=newton", "solver.max_iterations=10"});
  const pardel::MemoryEstimate e = pardel::estimate_solve_memory(s.problem, s.options);
  const double ratio = (ten.peak_bytes - base.peak_bytes) / std::max({e.solve, e.certificate, e.output});
  std::printf("method newton after refused steps, N = 60000: estimate %.1f MB, measured %.1f MB: ratio %.3f\n",
              std::max({e.solve, e.certificate, e.output}) / 1e6, (ten.peak_bytes - base.peak_bytes) / 1e6, ratio);
  EXPECT_GT(ratio, 0.75);
  EXPECT_LT(ratio, 1.25);
}

TEST_F(MemoryEstimate, RefusedUnderAnAddressSpaceLimit) {
  const Outcome o = run_pardel({"solve", scene_.string(), "--out", (dir_ / "refused").string(), "--set",
                                "grid.N=20000000", "--set", "solver.method=newton", "--no-plot", "--quiet"},
                               dir_ / "refused.log", 1.5e9);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("grid.N = 20000000 needs an estimated"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("RLIMIT_AS"), std::string::npos) << o.output;
  EXPECT_EQ(o.output.find("bad_alloc"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "refused")) << "nothing is written for a refused scene";
  EXPECT_LT(o.peak_bytes, 200e6) << "refused before allocating";
}

TEST_F(MemoryEstimate, BadAllocWithoutTheCheckBecomesAMessage) {
  const Outcome o = run_pardel({"solve", scene_.string(), "--out", (dir_ / "oom").string(), "--set",
                                "grid.N=20000000", "--set", "solver.method=newton", "--no-plot", "--quiet",
                                "--no-memory-check"},
                               dir_ / "oom.log", 1.5e9);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("out of memory (std::bad_alloc) while solving"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("grid.N = 20000000"), std::string::npos) << o.output;
}

TEST_F(MemoryEstimate, RefusedWhenTheMachineHasTooLittle) {
  const auto s = scene({"grid.N=100000000", "solver.method=hybrid"});
  const double need = pardel::estimate_solve_memory(s.problem, s.options).peak;
  const pardel::MachineMemory machine = pardel::machine_memory(need);
  if (machine.available < 0 || machine.available >= need) GTEST_SKIP() << "this machine has the memory";
  const Outcome o = run_pardel({"solve", scene_.string(), "--out", (dir_ / "huge").string(), "--set",
                                "grid.N=100000000", "--set", "solver.method=hybrid", "--no-plot", "--quiet"},
                               dir_ / "huge.log");
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("grid.N = 100000000 needs an estimated"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("available (MemAvailable in /proc/meminfo)"), std::string::npos) << o.output;
  EXPECT_LT(o.peak_bytes, 200e6);
}

TEST_F(MemoryEstimate, GridBeyondTheSceneLimitNamesTheKey) {
  const Outcome o = run_pardel({"solve", scene_.string(), "--set", "grid.N=2000000000", "--no-plot", "--quiet"},
                               dir_ / "limit.log");
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("grid.N must be between 2 and 100000000, got 2000000000"), std::string::npos) << o.output;
}

TEST_F(MemoryEstimate, MessageNamesTheMachineMemory) {
  pardel::MemoryEstimate e;
  e.peak = 5e9;
  e.largest = "solve";
  pardel::MachineMemory m;
  m.available = 2e9;
  const pardel::app::Scene s = scene({});
  const std::string why = pardel::memory_refusal(s.problem, s.options, e, m);
  EXPECT_NE(why.find("grid.N = 200 needs an estimated 5.00 GB (method jacobi-newton"), std::string::npos) << why;
  EXPECT_NE(why.find("this machine has 2.00 GB available"), std::string::npos) << why;
  m.available = 8e9;
  EXPECT_EQ(pardel::memory_refusal(s.problem, s.options, e, m), "");
}

}  // namespace

TEST(MachineMemory, AvailableIsReadForEstimatesOfSixteenMegabytesAndMore) {
  // Below 16 MB the solve does not read /proc/meminfo (a small solve's call spent 7 % of its time
  // there); from 16 MB it does, as the refusal of a grid the machine cannot hold needs.
  EXPECT_LT(pardel::machine_memory(1e6).available, 0);
  EXPECT_GT(pardel::machine_memory(16e6).available, 0);
}
