// Tests of the `pardel sweep` binary: the shipped 50-guess Zermelo sweep run plainly and under
// mpirun with two ranks (identical solutions.csv), the output files, the picture, exit codes.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
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

/** Runs a shell command line; captures stdout and stderr. */
Result run(const std::string& command_line) {
  static int counter = 0;
  const fs::path base =
      fs::temp_directory_path() / ("pardel_test_sweep_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  const std::string command =
      command_line + " >'" + base.string() + ".out' 2>'" + base.string() + ".err' </dev/null";
  const int status = std::system(command.c_str());
  Result r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(base.string() + ".out");
  r.err = slurp(base.string() + ".err");
  fs::remove(base.string() + ".out");
  fs::remove(base.string() + ".err");
  return r;
}

std::string pardel(const std::string& args) { return std::string("'") + PARDEL_BINARY + "' " + args; }

class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(fs::temp_directory_path() / ("pardel_test_sweep_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

const std::string kZermelo50 = std::string(PARDEL_SCENES_DIR) + "/sweeps/zermelo_50.toml";

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

/** variants.csv without its last column (seconds, which varies from run to run). */
std::string without_seconds(const std::string& csv) {
  std::string out;
  for (const auto& line : lines(csv)) out += line.substr(0, line.rfind(',')) + "\n";
  return out;
}

TEST(SweepCommand, Zermelo50WritesConsistentOutputs) {
  const TempDir dir("plain");
  const Result r = run(pardel("sweep '" + kZermelo50 + "' --out '" + dir / "out" + "' --no-plot"));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto summary = nlohmann::json::parse(slurp(dir / "out/sweep.json"));
  EXPECT_EQ(summary["variants"], 50);
  EXPECT_EQ(summary["ranks"], 1);
  EXPECT_EQ(summary["cost"]["name"], "travel_time");
  const int count = summary["solutions_count"];
  ASSERT_GE(count, 1);
  const auto solution_rows = lines(slurp(dir / "out/solutions.csv"));
  ASSERT_EQ(static_cast<int>(solution_rows.size()), count + 1);
  EXPECT_EQ(solution_rows[0], "solution,configuration,rank,cost,action,residual,variants,first_variant,certificate");
  const auto variant_rows = lines(slurp(dir / "out/variants.csv"));
  ASSERT_EQ(variant_rows.size(), 51u);
  // Every converged variant belongs to a solution; the solution counts add up.
  int members = 0;
  for (const auto& s : summary["solutions"]) members += s["variants"].get<int>();
  EXPECT_EQ(members, summary["converged"].get<int>());
  int failures = 0;
  for (const auto& [status, n] : summary["failures"].items()) failures += n.get<int>();
  EXPECT_EQ(summary["converged"].get<int>() + failures, 50);
  // Each solution's trajectory file reads back and is converged on the scene's problem.
  const pardel_model* model = find_model("zermelo");
  ASSERT_NE(model, nullptr);
  double previous = 0;
  for (const auto& s : summary["solutions"]) {
    const std::string file = dir / ("out/" + s["trajectory"].get<std::string>());
    const Trajectory trajectory = app::read_trajectory_csv(file, *model);
    EXPECT_EQ(trajectory.N, 80);
    const Result check = run(pardel("check '" + std::string(PARDEL_SCENES_DIR) + "/zermelo_1.toml' --json --trajectory '" +
                                    file + "'"));
    ASSERT_EQ(check.code, 0) << check.err;
    const auto certificate = nlohmann::json::parse(check.out);
    EXPECT_LE(certificate["residual"].get<double>(), 1e-10) << file;
    EXPECT_NEAR(certificate["action"].get<double>(), s["action"].get<double>(), 1e-12 * s["action"].get<double>());
    EXPECT_EQ(certificate["certificate"]["hessian_positive_definite"].get<bool>(), s["certificate"] == "minimum");
    EXPECT_GE(s["cost"].get<double>(), previous);
    previous = s["cost"].get<double>();
  }
  EXPECT_EQ(summary["best"]["id"], 1);
  EXPECT_NE(r.out.find("best: solution 1, travel_time = "), std::string::npos) << r.out;
}

TEST(SweepCommand, Zermelo50UnderMpirunWithTwoRanksGivesTheSameSolutions) {
#ifndef PARDEL_TEST_MPIEXEC
  GTEST_SKIP() << "this build has no MPI or no mpirun";
#else
  const TempDir dir("mpi");
  const Result plain = run(pardel("sweep '" + kZermelo50 + "' --out '" + dir / "plain" + "' --no-plot --quiet"));
  ASSERT_EQ(plain.code, 0) << plain.err;
  const Result mpi = run(std::string("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 '") +
                         PARDEL_TEST_MPIEXEC + "' -np 2 --oversubscribe " +
                         pardel("sweep '" + kZermelo50 + "' --out '" + dir / "mpi" + "' --no-plot --quiet"));
  ASSERT_EQ(mpi.code, 0) << mpi.err << mpi.out;
  const std::string solutions = slurp(dir / "plain/solutions.csv");
  ASSERT_FALSE(solutions.empty());
  EXPECT_EQ(slurp(dir / "mpi/solutions.csv"), solutions);
  EXPECT_EQ(without_seconds(slurp(dir / "mpi/variants.csv")), without_seconds(slurp(dir / "plain/variants.csv")));
  const auto summary = nlohmann::json::parse(slurp(dir / "mpi/sweep.json"));
  EXPECT_EQ(summary["ranks"], 2);
  for (const auto& s : summary["solutions"]) {
    const std::string name = s["trajectory"];
    EXPECT_EQ(slurp(dir / ("mpi/" + name)), slurp(dir / ("plain/" + name))) << name;
  }
#endif
}

TEST(SweepCommand, DrawsThePicture) {
  const TempDir dir("plot");
  const std::string sweep = dir / "three.toml";
  std::ofstream(sweep) << "scene = \"" << PARDEL_SCENES_DIR << "/zermelo_1.toml\"\n"
                       << "set = [\"solver.method=newton\"]\n"
                       << "[random_guesses]\ncount = 3\nspread = 2\n";
  const Result r = run(pardel("sweep '" + sweep + "' --out '" + dir / "out" + "' --quiet"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(r.out.empty()) << r.out;
  ASSERT_TRUE(fs::exists(dir / "out/sweep.png")) << r.err;
  EXPECT_GT(fs::file_size(dir / "out/sweep.png"), 10000u);
}

TEST(SweepCommand, BadSweepFileExitsWithTwoAndItsLocation) {
  const TempDir dir("bad");
  const std::string sweep = dir / "bad.toml";
  std::ofstream(sweep) << "scene = \"" << PARDEL_SCENES_DIR << "/zermelo_1.toml\"\n[random_guesses]\ncuont = 3\n";
  const Result r = run(pardel("sweep '" + sweep + "' --out '" + dir / "out" + "'"));
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, sweep + ":3:1: error: unknown key 'random_guesses.cuont'; did you mean 'random_guesses.count'?\n");
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(SweepCommand, NoConvergedVariantExitsWithEight) {
  const TempDir dir("none");
  const std::string sweep = dir / "none.toml";
  std::ofstream(sweep) << "scene = \"" << PARDEL_SCENES_DIR << "/zermelo_1.toml\"\n"
                       << "set = [\"solver.method=newton\", \"solver.max_iterations=1\"]\n"
                       << "[random_guesses]\ncount = 2\nspread = 1\n";
  const Result r = run(pardel("sweep '" + sweep + "' --out '" + dir / "out" + "' --quiet"));
  EXPECT_EQ(r.code, 8) << r.err;
  const auto summary = nlohmann::json::parse(slurp(dir / "out/sweep.json"));
  EXPECT_EQ(summary["converged"], 0);
  EXPECT_EQ(summary["failures"]["max_iterations"], 2);
  EXPECT_TRUE(summary["best"].is_null());
}

TEST(SweepCommand, EveryVariantInvalidExitsWithTwoAndSaysWhy) {
  // A mass of zero makes the model degenerate: each variant is refused as invalid input, the
  // reason on stderr and in variants.csv's error column, no residual or action, and exit 2.
  const TempDir dir("invalid");
  std::ofstream(dir / "spring.lag") << "model zero_mass_spring\ncoords x\nparam m = 1\nL = 1/2*m*x'^2 - 1/2*x^2\n";
  std::ofstream(dir / "spring.toml") << "model = \"spring.lag\"\n[grid]\nT = 1.0\nN = 20\n[boundary]\nq0 = [0.0]\n"
                                     << "qN = [1.0]\n";
  const std::string sweep = dir / "zero.toml";
  std::ofstream(sweep) << "scene = \"spring.toml\"\nset = [\"params.m=0\"]\n[random_guesses]\ncount = 2\nspread = 0.5\n";
  const Result r = run(pardel("sweep '" + sweep + "' --out '" + dir / "out" + "' --quiet --no-plot"));
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("pardel sweep: 2 variants not solved (first: variant 0): "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("every variant is invalid input"), std::string::npos) << r.err;
  const std::vector<std::string> rows = lines(slurp(dir / "out/variants.csv"));
  ASSERT_EQ(rows.size(), 3u);
  for (std::size_t i = 1; i < rows.size(); ++i) {
    EXPECT_NE(rows[i].find(",invalid_input,0,nan,nan,nan,"), std::string::npos) << rows[i];
    EXPECT_NE(rows[i].find("is degenerate"), std::string::npos) << rows[i];
  }
}

TEST(SweepCommand, OverridesOfVariedKeysAndBadSetEntriesAreRefusedWithTheirPlace) {
  const TempDir dir("sets");
  const std::string scene = std::string(PARDEL_SCENES_DIR) + "/zermelo_1.toml";
  const std::string varied = dir / "varied.toml";
  std::ofstream(varied) << "scene = \"" << scene << "\"\n[[vary]]\nkey = \"grid.N\"\nvalues = [40, 60]\n";
  // --set of a varied key: each variant's value would replace it unseen (and it was never checked).
  Result r = run(pardel("sweep '" + varied + "' --out '" + dir / "out" + "' --quiet --set grid.N=abc"));
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err, "--set grid.N=abc: error: the sweep varies grid.N (" + varied +
                       ":2:1): each variant's value would replace this override\n");
  // The sweep file's own set: its entry's place in the file.
  const std::string bad = dir / "bad_set.toml";
  std::ofstream(bad) << "scene = \"" << scene << "\"\nset = [\"solver.method=newton\", \"grid.NN=3\"]\n";
  r = run(pardel("sweep '" + bad + "' --out '" + dir / "out" + "' --quiet"));
  EXPECT_EQ(r.code, 2);
  EXPECT_EQ(r.err.rfind(bad + ":2:32: error: set[1] = \"grid.NN=3\": unknown key 'grid.NN'", 0), 0u) << r.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(SweepCommand, SigtermStopsTheSweepAndKeepsWhatWasDone) {
  // Jacobi-Newton needs some 24 000 sweeps on this scene (0.6 s a variant on the development
  // machine): ten variants take far longer than the two seconds before the signal.
  const TempDir dir("stop");
  const std::string sweep = dir / "slow.toml";
  std::ofstream(sweep) << "scene = \"" << PARDEL_SCENES_DIR << "/zermelo_1.toml\"\n"
                       << "set = [\"solver.method=jacobi-newton\", \"solver.threads=1\"]\n"
                       << "[random_guesses]\ncount = 10\nspread = 1\n";
  const Result r = run("(" + pardel("sweep '" + sweep + "' --out '" + dir / "out" + "' --no-plot --quiet") +
                       " & pid=$!; sleep 2; kill -TERM $pid; wait $pid)");
  EXPECT_EQ(r.code, 6) << r.err;
  EXPECT_NE(r.err.find("pardel sweep: interrupted"), std::string::npos) << r.err;
  // The variants started are listed; the others are counted. The signal lands mid-solve (that
  // variant, the last, is listed interrupted) or after a variant converged, during its error
  // estimate or point assessment, which it stops while the variant stays converged (a solve of
  // 0.6 s here spends about a tenth there): then every row is converged.
  const auto rows = lines(slurp(dir / "out/variants.csv"));
  ASSERT_GE(rows.size(), 2u);
  ASSERT_LE(rows.size(), 11u);
  int interrupted = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const bool stopped = rows[i].find(",interrupted,") != std::string::npos;
    interrupted += stopped;
    EXPECT_TRUE(stopped || rows[i].find(",converged,") != std::string::npos) << rows[i];
    if (stopped) EXPECT_EQ(i + 1, rows.size()) << "only the last variant started can be interrupted";
  }
  EXPECT_LE(interrupted, 1);
  const auto summary = nlohmann::json::parse(slurp(dir / "out/sweep.json"));
  // failures lists the statuses that occurred: no "interrupted" when the signal landed after a
  // variant converged.
  EXPECT_EQ(summary["failures"].value("interrupted", 0), interrupted);
  EXPECT_EQ(summary["variants"], 10);
  const int started = static_cast<int>(rows.size()) - 1;
  EXPECT_EQ(summary["not_started"], 10 - started);
  EXPECT_EQ(summary["converged"], started - interrupted);
}

}  // namespace
