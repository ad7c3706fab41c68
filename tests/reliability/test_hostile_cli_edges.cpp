// Hostile cases at the edges of the command line, each run against the built `pardel` under a time
// limit: sweeps into the folder of an earlier sweep (complete and interrupted), variants too large
// for the memory the process may use, a sweep of 10^7 variants stopped by SIGTERM (time to stop,
// resident memory), `--set` values holding a line break (solve, check, sweep, a sweep file's
// `set`), `pardel kernels` with a step or a point that is not a finite positive number, the
// pictures of an earlier solve beside new outputs (a failed or skipped plot step), and plot.py on
// a model file that is not UTF-8.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "pardel_process.hpp"

namespace {

using namespace reliability;
using json = nlohmann::json;

const std::string kScenes = std::string(PARDEL_SOURCE_DIR) + "/scenes";
const std::string kSweep50 = kScenes + "/sweeps/zermelo_50.toml";

class HostileCliEdges : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = scratch_folder("pardel_hostile_cli_edges"); }
  void TearDown() override { fs::remove_all(dir_); }

  Outcome pardel(const std::vector<std::string>& args, int limit_s = 120, const std::vector<std::string>& env = {}) {
    return run_pardel(args, dir_ / "log", env, limit_s);
  }
  /** pardel under `ulimit -v KB` (RLIMIT_AS), through /bin/sh. */
  Outcome pardel_limited(long kb, const std::string& args, int limit_s = 120) {
    return finish_pardel(start_program("/bin/sh", {"-c", "ulimit -v " + std::to_string(kb) + " && exec '" +
                                                             std::string(PARDEL_CLI_PATH) + "' " + args},
                                       dir_ / "log"),
                         dir_ / "log", limit_s);
  }
  /** The solution_<id>.csv files in `out`. */
  static std::set<std::string> solution_files(const fs::path& out) {
    std::set<std::string> found;
    const std::regex name("solution_[0-9]+\\.csv");
    for (const auto& entry : fs::directory_iterator(out)) {
      const std::string file = entry.path().filename().string();
      if (std::regex_match(file, name)) found.insert(file);
    }
    return found;
  }
  /** The trajectory files sweep.json lists. */
  static std::set<std::string> listed_solution_files(const fs::path& out) {
    std::set<std::string> listed;
    const json index = json::parse(read_text(out / "sweep.json"));
    for (const auto& s : index["solutions"])
      listed.insert(s["trajectory"].get<std::string>());
    return listed;
  }
  static std::size_t line_count(const std::string& text) {
    return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
  }
  /** A sweep file over zermelo_1.toml with `body` after the scene line. */
  fs::path sweep_file(const std::string& name, const std::string& body) {
    const fs::path path = dir_ / name;
    write_text(path, "scene = \"" + kScenes + "/zermelo_1.toml\"\n" + body);
    return path;
  }
  fs::path dir_;
};

// ---------------------------------------------------------------------------------------------
// A signal while a .lag compiles

/** Whether any running process's command line names `text` (the scratch folder of this test). */
bool process_naming(const std::string& text) {
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || !std::isdigit(static_cast<unsigned char>(name[0]))) continue;
    std::string cmdline = read_text(entry.path() / "cmdline");
    std::replace(cmdline.begin(), cmdline.end(), '\0', ' ');
    if (cmdline.find(text) != std::string::npos) return true;
  }
  return false;
}

/** Whether a temporary entry (NAME.tmp.*) lies anywhere under `dir`. */
bool temporary_entry_under(const fs::path& dir) {
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->path().filename().string().find(".tmp.") != std::string::npos) return true;
  return false;
}

TEST_F(HostileCliEdges, SignalWhileAModelCompilesStopsTheCompileAndEndsInterrupted) {
  // Ctrl-C or SIGTERM while `pardel solve` compiled a .lag killed pardel at once (exit 130 or 143,
  // no message) and left the compiler running on, detached (its own process group), with its
  // temporary folder in the cache. Now the compile is stopped, the folder removed, and the
  // command ends with the interrupted status and a message.
  int round = 0;
  const std::pair<int, const char*> cases[] = {{SIGINT, "solve"}, {SIGTERM, "solve"}, {SIGINT, "kernels"},
                                               {SIGTERM, "sweep"}};
  for (const auto& [signal, command] : cases) {
    SCOPED_TRACE(std::string(command) + (signal == SIGINT ? " SIGINT" : " SIGTERM"));
    const fs::path cache = dir_ / ("cache" + std::to_string(round));
    const fs::path lag = dir_ / ("slow" + std::to_string(round) + ".lag");
    ++round;
    // Four coordinates under two Galerkin discretizations of high degree: seconds to compile.
    write_text(lag, "model slow\ncoords a b c d\nL = 1/2*(a'^2+b'^2+c'^2+d'^2) + cos(a*b+c)*sin(b*d-a)*exp(-c^2) + "
                    "log(2+sin(a)^2*cos(d)^2) + (a*b*c*d)^2/(1+a^2+b^2)\n"
                    "discretizations trapezoid galerkin_gauss(s=6) galerkin_lobatto(s=5)\n");
    const fs::path scene = dir_ / "slow.toml";
    write_text(scene, "model = \"" + lag.string() + "\"\ndiscretization = \"trapezoid\"\n[grid]\nT = 1\nN = 20\n"
                      "[boundary]\nq0 = [0, 0, 0, 0]\nqN = [1, 1, 1, 1]\n");
    const fs::path sweep = dir_ / "slow_sweep.toml";
    write_text(sweep, "scene = \"" + scene.string() + "\"\n[[vary]]\nkey = \"grid.N\"\nvalues = [10, 20]\n");
    const std::string name = command;
    const std::vector<std::string> args =
        name == "solve"     ? std::vector<std::string>{"solve", scene.string(), "--out", (dir_ / "out").string(),
                                                       "--no-plot", "--quiet"}
        : name == "kernels" ? std::vector<std::string>{"kernels", "--model", lag.string(), "--disc", "trapezoid", "--h",
                                                       "0.1", "--t0", "0", "--t1", "0.1", "--q0", "0,0,0,0", "--q1",
                                                       "1,1,1,1"}
                            : std::vector<std::string>{"sweep", sweep.string(), "--out", (dir_ / "sweep_out").string(),
                                                       "--no-plot", "--quiet"};
    const pid_t pid = start_pardel(args, dir_ / "log", {"PARDEL_CACHE_DIR=" + cache.string()});
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (!temporary_entry_under(cache) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    ASSERT_TRUE(temporary_entry_under(cache)) << "the compile did not start";
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ::kill(pid, signal);
    const Outcome o = finish_pardel(pid, dir_ / "log", 60);
    ASSERT_FALSE(o.timed_out) << o.output;
    EXPECT_EQ(o.status, 6) << o.output;
    EXPECT_NE(o.output.find("interrupted while compiling"), std::string::npos) << o.output;
    EXPECT_FALSE(temporary_entry_under(cache));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    EXPECT_FALSE(process_naming(cache.string())) << "a program of the compile runs on";
  }
}

/** Whether a child of `parent` runs a command line that names `text`. */
bool child_naming(pid_t parent, const std::string& text) {
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || !std::isdigit(static_cast<unsigned char>(name[0]))) continue;
    const std::string stat = read_text(entry.path() / "stat");  // "PID (COMM) STATE PPID ..."
    const auto close = stat.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(stat.substr(close + 1));
    std::string state;
    long ppid = 0;
    rest >> state >> ppid;
    if (ppid != parent) continue;
    std::string cmdline = read_text(entry.path() / "cmdline");
    std::replace(cmdline.begin(), cmdline.end(), '\0', ' ');
    if (cmdline.find(text) != std::string::npos) return true;
  }
  return false;
}

TEST_F(HostileCliEdges, SigtermDuringThePlotStepEndsThePlotScriptToo) {
  // SIGTERM to pardel while plot.py drew ended pardel (as documented) but left plot.py running,
  // to write its pictures into the folder later, beside whatever came there next.
  const fs::path out = dir_ / "plotted";
  const pid_t pid = start_pardel({"solve", kScenes + "/fuel_nav.toml", "--set", "grid.N=20000", "--out", out.string()},
                                 dir_ / "log");
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!child_naming(pid, "plot.py") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(child_naming(pid, "plot.py")) << "the plot step did not start";
  ::kill(pid, SIGTERM);
  const Outcome o = finish_pardel(pid, dir_ / "log", 60);
  ASSERT_FALSE(o.timed_out) << o.output;
  EXPECT_EQ(o.status, 128 + SIGTERM) << o.output;
  EXPECT_NE(o.output.find("plots not written: stopped by SIGTERM"), std::string::npos) << o.output;
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  EXPECT_FALSE(process_naming(out.string())) << "plot.py runs on";
  EXPECT_FALSE(fs::exists(out / "trajectory.png"));
  EXPECT_FALSE(fs::exists(out / "convergence.png"));
}

// ---------------------------------------------------------------------------------------------
// Sweeps

TEST_F(HostileCliEdges, SmallerSweepIntoAnEarlierSweepsFolderLeavesNoneOfItsFiles) {
  const fs::path out = dir_ / "out";
  Outcome o = pardel({"sweep", kSweep50, "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(o.status, 0) << o.output;
  ASSERT_GE(solution_files(out).size(), 3u);
  write_text(out / "sweep.png", "the earlier sweep's picture");
  const fs::path one = sweep_file("one.toml", "[[guesses]]\npoints = [[0,0],[1,3.5],[4,5.5],[6,2]]\n");
  o = pardel({"sweep", one.string(), "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(solution_files(out), (std::set<std::string>{"solution_1.csv"}));
  EXPECT_EQ(listed_solution_files(out), (std::set<std::string>{"solution_1.csv"}));
  EXPECT_FALSE(fs::exists(out / "sweep.png")) << "the earlier sweep's picture is left beside the new outputs";
  EXPECT_EQ(line_count(read_text(out / "variants.csv")), 2u);
  EXPECT_TRUE(temporary_files(out).empty());
}

TEST_F(HostileCliEdges, InterruptedSweepIntoAnEarlierSweepsFolderListsOnlyItsOwnSolutions) {
  const fs::path out = dir_ / "out";
  Outcome o = pardel({"sweep", kSweep50, "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(o.status, 0) << o.output;
  ASSERT_GE(solution_files(out).size(), 3u);
  // Jacobi-Newton needs some 30 000 sweeps per variant here: SIGTERM comes long before the end.
  const fs::path slow = sweep_file("slow.toml", "set = [\"solver.method=jacobi-newton\", \"solver.threads=1\"]\n"
                                                "[random_guesses]\ncount = 10\nspread = 1\n");
  const pid_t pid = start_pardel({"sweep", slow.string(), "--out", out.string(), "--no-plot", "--quiet"}, dir_ / "log");
  std::this_thread::sleep_for(std::chrono::seconds(2));
  ::kill(pid, SIGTERM);
  o = finish_pardel(pid, dir_ / "log", 60);
  ASSERT_FALSE(o.timed_out) << o.output;
  ASSERT_EQ(o.status, 6) << o.output;
  // Every solution file in the folder is one the new sweep.json lists.
  EXPECT_EQ(solution_files(out), listed_solution_files(out));
  const json summary = json::parse(read_text(out / "sweep.json"));
  EXPECT_EQ(summary["variants"], 10);
  const std::size_t rows = line_count(read_text(out / "variants.csv")) - 1;
  EXPECT_EQ(rows + summary["not_started"].get<std::size_t>(), 10u) << read_text(out / "variants.csv");
  EXPECT_NE(o.output.find("not started"), std::string::npos) << o.output;
}

/** Where a sweep into an earlier sweep's folder is killed: at the rename of one of its files. */
struct SweepKillPoint {
  const char* file;
  const char* when;  ///< "before" or "after" the rename
};

class SweepKilledWhileWriting : public HostileCliEdges, public ::testing::WithParamInterface<SweepKillPoint> {};

TEST_P(SweepKilledWhileWriting, NeverLeavesAnIndexWithFilesOfAnotherSweep) {
  const fs::path out = dir_ / "out";
  Outcome o = pardel({"sweep", kSweep50, "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(o.status, 0) << o.output;
  ASSERT_GE(solution_files(out).size(), 3u);
  // Three guesses of another seed: other solutions, fewer of them.
  const fs::path other = sweep_file("other.toml", "set = [\"solver.method=newton\"]\n[random_guesses]\ncount = 3\n"
                                                  "seed = 7\nbox = { min = [-1, -2], max = [8, 7] }\n");
  o = run_pardel({"sweep", other.string(), "--out", out.string(), "--no-plot", "--quiet"}, dir_ / "log",
                 {std::string("LD_PRELOAD=") + PARDEL_FAULT_INJECT_PATH, std::string("PARDEL_FAULT_RENAME=") + GetParam().file,
                  std::string("PARDEL_FAULT_WHEN=") + GetParam().when, "PARDEL_FAULT_SIGNAL=9"},
                 120);
  ASSERT_FALSE(o.timed_out) << o.output;
  EXPECT_EQ(o.status, 128 + SIGKILL) << o.output;
  // Whenever sweep.json exists, the files beside it are the ones it lists (and of its sweep).
  if (fs::exists(out / "sweep.json")) {
    const json index = json::parse(read_text(out / "sweep.json"));
    EXPECT_EQ(index["sweep"], other.string());
    EXPECT_EQ(solution_files(out), listed_solution_files(out));
    EXPECT_EQ(line_count(read_text(out / "solutions.csv")), index["solutions_count"].get<std::size_t>() + 1);
    EXPECT_EQ(line_count(read_text(out / "variants.csv")), 4u);
  } else {
    EXPECT_TRUE(solution_files(out).size() <= 3u) << "the earlier sweep's solution files are left";
  }
  // The next sweep into the folder completes and removes what the killed one left behind.
  o = pardel({"sweep", other.string(), "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(solution_files(out), listed_solution_files(out));
  EXPECT_TRUE(temporary_files(out).empty()) << temporary_files(out).front();
}

INSTANTIATE_TEST_SUITE_P(
    EachRename, SweepKilledWhileWriting,
    ::testing::Values(SweepKillPoint{"solution_1.csv", "before"}, SweepKillPoint{"solutions.csv", "before"},
                      SweepKillPoint{"variants.csv", "before"}, SweepKillPoint{"sweep.json", "before"},
                      SweepKillPoint{"sweep.json", "after"}),
    [](const ::testing::TestParamInfo<SweepKillPoint>& info) {
      std::string name = std::string(info.param.when) + "_" + info.param.file;
      for (char& c : name)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
      return name;
    });

TEST_F(HostileCliEdges, VariantTooLargeForMemoryIsRefusedWithItsReason) {
  // (ulimit -v: were the check missing, the allocation would fail instead of taking the machine.)
  const fs::path sweep = sweep_file("large.toml", "set = [\"solver.method=newton\", \"solver.threads=1\"]\n"
                                                  "[[vary]]\nkey = \"grid.N\"\nvalues = [40, 100000000]\n");
  const fs::path out = dir_ / "out";
  const Outcome o = pardel_limited(4000000, "sweep '" + sweep.string() + "' --out '" + out.string() + "' --no-plot");
  ASSERT_FALSE(o.timed_out) << o.output;
  EXPECT_EQ(o.status, 0) << o.output;  // the N = 40 variant converged
  EXPECT_NE(o.output.find("pardel sweep: 1 variant not solved (first: variant 1): refused before solving: grid.N = "
                          "100000000 needs an estimated"),
            std::string::npos)
      << o.output;
  const std::string variants = read_text(out / "variants.csv");
  EXPECT_NE(variants.find(",error,"), std::string::npos) << variants;
  EXPECT_NE(variants.find("refused before solving: grid.N = 100000000"), std::string::npos) << variants;
  EXPECT_EQ(json::parse(read_text(out / "sweep.json"))["failures"]["error"], 1);
}

TEST_F(HostileCliEdges, EveryVariantTooLargeEndsWithNoSolutionAndTheReason) {
  const fs::path sweep = sweep_file("all_large.toml", "set = [\"solver.method=newton\", \"grid.N=100000000\"]\n"
                                                      "[random_guesses]\ncount = 3\nspread = 1\n");
  const fs::path out = dir_ / "out";
  const Outcome o = pardel_limited(4000000, "sweep '" + sweep.string() + "' --out '" + out.string() + "' --no-plot");
  ASSERT_FALSE(o.timed_out) << o.output;
  EXPECT_EQ(o.status, 8) << o.output;
  EXPECT_NE(o.output.find("pardel sweep: 3 variants not solved (first: variant 0): refused before solving"),
            std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("--no-memory-check skips this check"), std::string::npos) << o.output;
}

TEST_F(HostileCliEdges, TenMillionVariantsStopSoonAfterSigtermInBoundedMemory) {
  // 10^6 random guesses (the most) x 10 configurations = 10^7 variants (the most).
  const fs::path sweep =
      sweep_file("huge.toml", "set = [\"solver.method=newton\", \"grid.N=20\", \"solver.threads=1\"]\n"
                              "[random_guesses]\ncount = 1000000\ninterior_points = 1\nspread = 1\n"
                              "[[vary]]\nkey = \"params.s\"\nfrom = 1.0\nto = 1.9\ncount = 10\n");
  const fs::path out = dir_ / "out";
  const pid_t pid = start_pardel({"sweep", sweep.string(), "--out", out.string(), "--no-plot", "--quiet"}, dir_ / "log");
  std::this_thread::sleep_for(std::chrono::seconds(4));
  long rss_kb = -1;
  {
    std::ifstream status("/proc/" + std::to_string(pid) + "/status");
    for (std::string line; std::getline(status, line);)
      if (line.rfind("VmRSS:", 0) == 0) rss_kb = std::stol(line.substr(6));
  }
  const auto signalled = std::chrono::steady_clock::now();
  ::kill(pid, SIGTERM);
  const Outcome o = finish_pardel(pid, dir_ / "log", 60);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - signalled).count();
  ASSERT_FALSE(o.timed_out) << o.output;
  ASSERT_EQ(o.status, 6) << o.output;
  EXPECT_LT(seconds, 2.0) << "a sweep of 10^7 variants took " << seconds << " s to stop after SIGTERM";
  EXPECT_GT(rss_kb, 0);
  EXPECT_LT(rss_kb, 400 * 1024) << "resident memory of the running sweep: " << rss_kb << " kB";
  const json summary = json::parse(read_text(out / "sweep.json"));
  EXPECT_EQ(summary["variants"], 10000000);
  const std::size_t rows = line_count(read_text(out / "variants.csv")) - 1;
  EXPECT_GT(rows, 0u);
  EXPECT_EQ(rows + summary["not_started"].get<std::size_t>(), 10000000u);
}

TEST_F(HostileCliEdges, SweepFileSetWithALineBreakIsRefused) {
  const fs::path sweep = sweep_file("newline.toml", "set = [\"grid.N=40\\nsolver.tol=1\"]\n");
  const Outcome o = pardel({"sweep", sweep.string(), "--no-plot", "--quiet", "--out", (dir_ / "out").string()});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find(sweep.string() + ":2:8: error: set[0] holds a line break"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// ---------------------------------------------------------------------------------------------
// --set with a line break: the text after it would be dropped unseen

TEST_F(HostileCliEdges, SolveSetWithALineBreakIsRefused) {
  const Outcome o = pardel({"solve", kScenes + "/zermelo_1.toml", "--set", "grid.N=40\nsolver.tol=1", "--out",
                            (dir_ / "out").string(), "--no-plot", "--quiet"});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("--set grid.N=40\\nsolver.tol=1: error: the override holds a line break"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(HostileCliEdges, CheckSetWithACarriageReturnIsRefused) {
  const Outcome o = pardel({"check", kScenes + "/zermelo_1.toml", "--set", "grid.N=40\r"});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("--set grid.N=40\\r: error: the override holds a line break"), std::string::npos)
      << o.output;
}

TEST_F(HostileCliEdges, CheckOfATrajectoryOfAnotherProblemIsRefused) {
  // A solution of zermelo_1 checked against the same scene with another boundary.qN: refused with
  // the node and the component, not a certificate of a problem the scene does not pose.
  const fs::path out = dir_ / "solved";
  const Outcome solved = pardel({"solve", kScenes + "/zermelo_1.toml", "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(solved.status, 0) << solved.output;
  const std::string csv = (out / "trajectory.csv").string();
  const Outcome same = pardel({"check", kScenes + "/zermelo_1.toml", "--trajectory", csv});
  EXPECT_EQ(same.status, 0) << same.output;
  const Outcome other = pardel({"check", kScenes + "/zermelo_1.toml", "--set", "boundary.qN=[7, 2]", "--trajectory", csv});
  EXPECT_EQ(other.status, 2) << other.output;
  EXPECT_NE(other.output.find("the scene's boundary.qN has x = 7: the trajectory is a path of another boundary-value problem"),
            std::string::npos)
      << other.output;
}

TEST_F(HostileCliEdges, CheckOfATrajectoryOnOtherTimesOrOffAKnotIsRefused) {
  // A solution of min_jerk (knots at t = 1 and t = 3, N = 40 on [0, 4]) checked against scenes
  // that differ only in their node times or knots: refused with the node, not a residual and
  // certificate of a problem the scene does not pose.
  const fs::path out = dir_ / "solved";
  const std::string scene = kScenes + "/min_jerk.toml";
  const Outcome solved = pardel({"solve", scene, "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(solved.status, 0) << solved.output;
  const std::string csv = (out / "trajectory.csv").string();
  const Outcome same = pardel({"check", scene, "--trajectory", csv});
  EXPECT_EQ(same.status, 0) << same.output;
  struct Case {
    std::vector<std::string> sets;
    const char* message;
  };
  const Case cases[] = {
      {{"grid.t0=1", "knots=[]"}, "node 0 has t = 0, the scene places it at t = 1 (grid.t0 = 1, grid.T = 4, N = 40): the "
                      "trajectory lies on other node times"},
      {{"grid.T=8", "knots=[]"}, "node 1 has t = 0.1, the scene places it at t = 0.2"},
      {{"knots=[{t = 2, q = [2, 0, 0]}]"}, "node 20 (t = 2) has y = "},
      // The scene's own grid (N = 3) has the knot on a node; the trajectory's (N = 40) does not.
      {{"grid.N=3", "knots=[{t = 1.3333333333333333, q = [1, 2, 1]}]"},
       "the scene's knot 0 at t = 1.3333333333333333 is on no interior node of the trajectory (N = 40)"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {"check", scene, "--trajectory", csv};
    for (const std::string& set : c.sets) args.insert(args.end(), {"--set", set});
    const Outcome o = pardel(args);
    EXPECT_EQ(o.status, 2) << o.output;
    EXPECT_NE(o.output.find(c.message), std::string::npos) << o.output;
  }
}

TEST_F(HostileCliEdges, CheckOfAnAdaptiveSolutionTakesItsOwnNodes) {
  // An adaptive scene (grid.accuracy) chooses a non-uniform grid: its solution is checked on its own
  // node times (the residual the solve reported), and a path on other times is still refused.
  const fs::path scene = dir_ / "adaptive.toml";
  write_text(scene, "model = \"pendulum\"\ndiscretization = \"midpoint\"\n[grid]\nT = 2.0\naccuracy = 1e-6\n"
                    "[boundary]\nq0 = [0]\nqN = [1]\n");
  const fs::path out = dir_ / "adaptive";
  const Outcome solved = pardel({"solve", scene.string(), "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(solved.status, 0) << solved.output;
  const Outcome same = pardel({"check", scene.string(), "--trajectory", (out / "trajectory.csv").string(), "--json"});
  ASSERT_EQ(same.status, 0) << same.output;
  const nlohmann::json checked = nlohmann::json::parse(same.output.substr(same.output.find('{')));
  const nlohmann::json summary = nlohmann::json::parse(read_text(out / "summary.json"));
  EXPECT_EQ(checked["N"].get<int>(), summary["N"].get<int>());
  // The same residual up to the rounding of another kernel (on the uniform grid of that N it is
  // many orders of magnitude larger).
  EXPECT_NEAR(checked["residual"].get<double>(), summary["residual"].get<double>(),
              1e-6 * summary["residual"].get<double>());
  const Outcome later = pardel({"check", scene.string(), "--trajectory", (out / "trajectory.csv").string(), "--set",
                                "grid.T=3"});
  EXPECT_EQ(later.status, 2) << later.output;
  EXPECT_NE(later.output.find("the scene places it at t = 3 (grid.t0 + grid.T)"), std::string::npos) << later.output;
}

TEST_F(HostileCliEdges, SweepSetWithALineBreakIsRefused) {
  const Outcome o = pardel({"sweep", kSweep50, "--set", "solver.tol=1e-8\ngrid.N=3", "--out",
                            (dir_ / "out").string(), "--no-plot", "--quiet"});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("--set solver.tol=1e-8\\ngrid.N=3: error: the override holds a line break"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

// ---------------------------------------------------------------------------------------------
// pardel kernels: the step and the points must be finite, the step positive

struct KernelCase {
  const char* option;
  const char* value;
  const char* message;
};

class KernelArguments : public HostileCliEdges, public ::testing::WithParamInterface<KernelCase> {};

TEST_P(KernelArguments, AreRefusedNamingTheArgument) {
  std::vector<std::string> args = {"kernels", "--model", "harmonic", "--disc", "trapezoid", "--h", "0.1",
                                   "--t0", "0", "--t1", "0.1", "--q0", "0", "--q1", "0.1"};
  bool replaced = false;
  for (std::size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] == GetParam().option) {
      args[i + 1] = GetParam().value;
      replaced = true;
    }
  }
  if (!replaced) args.insert(args.end(), {GetParam().option, GetParam().value});
  const Outcome o = pardel(args, 30);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find(std::string("pardel: error: ") + GetParam().message), std::string::npos) << o.output;
  EXPECT_EQ(o.output.find("\"Ld\""), std::string::npos) << o.output;
}

INSTANTIATE_TEST_SUITE_P(
    HostileCliEdges, KernelArguments,
    ::testing::Values(KernelCase{"--h", "0", "--h: the step must be a finite number > 0, got '0'"},
                      KernelCase{"--h", "-0.1", "--h: the step must be a finite number > 0, got '-0.1'"},
                      KernelCase{"--h", "nan", "--h: the step must be a finite number > 0, got 'nan'"},
                      KernelCase{"--h", "inf", "--h: the step must be a finite number > 0, got 'inf'"},
                      KernelCase{"--t0", "nan", "--t0: 'nan' is not a finite number"},
                      KernelCase{"--t1", "-inf", "--t1: '-inf' is not a finite number"},
                      KernelCase{"--q0", "nan", "--q0: value 1 (x) is not a finite number"},
                      KernelCase{"--q1", "1e999", "--q1: '1e999' is out of the range of a double (it overflows)"},
                      KernelCase{"--h", "1e-320",
                                 "--h: '1e-320' is out of the range of a double (it underflows to a subnormal or zero)"},
                      KernelCase{"--t0", "0x", "--t0: '0x' is not a number"},
                      KernelCase{"--param", "omega=nan", "--param omega: 'nan' is not a finite number"}),
    [](const ::testing::TestParamInfo<KernelCase>& info) { return "Case" + std::to_string(info.index); });

TEST_F(HostileCliEdges, KernelsThatOverflowExitWithTheNonFiniteStatus) {
  // L = (x'^2 - x^2)/2 at x = 1e200 over a step of 1e308: Ld and D1 overflow; the JSON has null for
  // them, and the exit code says that values are not finite.
  const Outcome o = pardel({"kernels", "--model", "harmonic", "--disc", "trapezoid", "--h", "1e308", "--t0", "0",
                            "--t1", "1e308", "--q0", "1e200", "--q1", "0.1"},
                           30);
  EXPECT_EQ(o.status, 5) << o.output;
  EXPECT_NE(o.output.find("\"Ld\": null"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("pardel kernels: error: 2 of the values are not finite (null in the JSON)"), std::string::npos)
      << o.output;
}

TEST_F(HostileCliEdges, KernelsSayWhenTheStepIsNotTheIntervalOfAModelWithoutAClock) {
  const Outcome o = pardel({"kernels", "--model", "harmonic", "--disc", "trapezoid", "--h", "0.1", "--t0", "5",
                            "--t1", "0.1", "--q0", "0", "--q1", "0.1"},
                           30);
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find("pardel kernels: note: --h 0.1 is not --t1 - --t0 = "), std::string::npos) << o.output;
  const Outcome same = pardel({"kernels", "--model", "harmonic", "--disc", "trapezoid", "--h", "0.1", "--t0", "5",
                               "--t1", "5.1", "--q0", "0", "--q1", "0.1"},
                              30);
  EXPECT_EQ(same.status, 0) << same.output;
  EXPECT_EQ(same.output.find("note:"), std::string::npos) << same.output;
}

// ---------------------------------------------------------------------------------------------
// Pictures: never those of another solve beside the outputs

TEST_F(HostileCliEdges, SolveWithoutPlotsRemovesTheEarlierSolvesPictures) {
  const fs::path out = dir_ / "out";
  fs::create_directories(out);
  write_text(out / "trajectory.png", "an earlier solve's picture");
  write_text(out / "convergence.png", "an earlier solve's picture");
  const Outcome o = pardel({"solve", kScenes + "/zermelo_1.toml", "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  EXPECT_FALSE(fs::exists(out / "trajectory.png"));
  EXPECT_FALSE(fs::exists(out / "convergence.png"));
}

TEST_F(HostileCliEdges, FailedPlotStepLeavesNoPicturesOfTheEarlierSolve) {
  const fs::path out = dir_ / "out";
  fs::create_directories(out);
  write_text(out / "trajectory.png", "an earlier solve's picture");
  write_text(out / "convergence.png", "an earlier solve's picture");
  // A matplotlib that cannot be imported: the plot step fails.
  fs::create_directories(dir_ / "broken" / "matplotlib");
  write_text(dir_ / "broken" / "matplotlib" / "__init__.py", "raise ImportError('broken for the test')\n");
  const Outcome o = pardel({"solve", kScenes + "/zermelo_1.toml", "--out", out.string(), "--quiet"}, 120,
                           {"PYTHONPATH=" + (dir_ / "broken").string()});
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find("warning: plots not written"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(out / "trajectory.png"));
  EXPECT_FALSE(fs::exists(out / "convergence.png"));
}

TEST_F(HostileCliEdges, PlotOfAModelFileInLatin1DrawsWithoutATraceback) {
  const fs::path out = dir_ / "out";
  const Outcome o = pardel({"solve", kScenes + "/zermelo_1.toml", "--out", out.string(), "--no-plot", "--quiet"});
  ASSERT_EQ(o.status, 0) << o.output;
  // The same model file with a comment in Latin-1 (0xE9, 'é', is not UTF-8 on its own).
  const fs::path lag = dir_ / "zermelo_latin1.lag";
  write_text(lag, "# vent fort, d\xe9rive\n" + read_text(std::string(PARDEL_SOURCE_DIR) + "/lagrangians/zermelo.lag"));
  json summary = json::parse(read_text(out / "summary.json"));
  summary["model_source"] = lag.string();
  write_text(out / "summary.json", summary.dump(2));
  const Outcome plot = finish_pardel(start_program(PARDEL_PYTHON_PATH, {PARDEL_PLOT_SCRIPT_PATH, out.string()},
                                                   dir_ / "plot.log"),
                                     dir_ / "plot.log", 120);
  ASSERT_FALSE(plot.timed_out);
  EXPECT_EQ(plot.status, 0) << plot.output;
  EXPECT_EQ(plot.output.find("Traceback"), std::string::npos) << plot.output;
  EXPECT_TRUE(fs::exists(out / "trajectory.png"));
  EXPECT_TRUE(fs::exists(out / "convergence.png"));
}

}  // namespace
