// Fault injection into `pardel solve`: SIGTERM while it iterates must end it with status 6 and
// a checkpoint, `pardel solve --resume` must continue to the same result as an uninterrupted run
// (trajectory.csv identical), and a corrupt, edited or mismatched checkpoint must be refused with
// exit status 2 and a message naming the file and what is wrong.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "pardel/app/checkpoint.hpp"
#include "pardel/pardel.hpp"
#include "pardel/app/scene.hpp"

namespace {

namespace fs = std::filesystem;
using pardel::app::Checkpoint;

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

struct Outcome {
  int status = -1;  ///< exit status, or 128 + signal
  std::string output;
};

int decode(int wstatus) { return WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus); }

/** Runs pardel with the arguments, stdout and stderr to a file; returns status and output. */
Outcome run_pardel(const std::vector<std::string>& args, const fs::path& log) {
  std::string cmd = std::string("'") + PARDEL_CLI_PATH + "'";
  for (const auto& a : args) cmd += " '" + a + "'";
  cmd += " > '" + log.string() + "' 2>&1";
  Outcome o;
  o.status = decode(std::system(cmd.c_str()));
  o.output = read_text(log);
  return o;
}

/** The convergence history without its wall-time column. */
std::string without_seconds(const std::string& csv) {
  std::istringstream in(csv);
  std::string line, out;
  while (std::getline(in, line)) out += line.substr(0, line.rfind(',')) + "\n";
  return out;
}

class CheckpointCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("pardel_checkpoint_cli_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // fuel_nav with a tolerance it cannot reach: the run ends at max_iterations, after a few
    // seconds on a 2-core machine, with the same iterate however it was interrupted.
    scene_ = dir_ / "long.toml";
    write_text(scene_,
               "model = \"fuel_nav\"\ndiscretization = \"trapezoid\"\n[grid]\nt0 = 0\nT = 30\nN = 1000\n"
               "[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n[guess]\nkind = \"linear\"\n"
               "[solver]\nmethod = \"jacobi-newton\"\ntol = 1e-15\nmax_iterations = 10000\n");
    reference_ = run_pardel({"solve", scene_.string(), "--out", (dir_ / "reference").string(), "--threads", "1",
                             "--no-plot", "--quiet"},
                            dir_ / "reference.log");
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  /** A valid checkpoint of `scene_path` at iteration K written without a signal (in-process solve). */
  static fs::path make_checkpoint(const std::string& name, long K, const fs::path& scene_path = scene_) {
    const pardel::app::Scene scene = pardel::app::load_scene(
        scene_path.string(), {}, [](const std::string& n) { return pardel::find_model(n); });
    pardel::Options options = scene.options;
    options.threads = 1;
    options.on_iteration = [K](const pardel::IterationRecord& r) { return r.iteration < K; };
    pardel::Trajectory trajectory = pardel::app::make_initial_guess(scene);
    const pardel::Summary summary = pardel::solve(scene.problem, options, trajectory);
    EXPECT_EQ(summary.termination, pardel::Termination::interrupted);
    Checkpoint c;
    c.scene_path = scene_path.string();
    c.scene_hash = pardel::app::fnv1a_hex(read_text(scene_path));
    c.threads = 1;
    c.model = "fuel_nav";
    c.dim = 2;
    c.model_digest = pardel::app::model_digest(*pardel::find_model("fuel_nav"));
    c.state = summary.state;
    const fs::path out = dir_ / name;
    fs::create_directories(out);
    pardel::app::write_checkpoint(out.string(), c);
    return out;
  }

  void expect_refused(const fs::path& out, const std::string& expected) {
    const Outcome o = run_pardel({"solve", "--resume", out.string(), "--no-plot", "--quiet"}, out / "resume.log");
    EXPECT_EQ(o.status, 2) << o.output;
    EXPECT_NE(o.output.find(expected), std::string::npos) << o.output;
  }

  static fs::path dir_, scene_;
  static Outcome reference_;
};

fs::path CheckpointCli::dir_, CheckpointCli::scene_;
Outcome CheckpointCli::reference_;

TEST_F(CheckpointCli, SigtermWritesACheckpointAndResumeReachesTheSameTrajectory) {
  ASSERT_EQ(reference_.status, 3) << reference_.output;  // max_iterations
  const fs::path out = dir_ / "interrupted";
  // The child's stderr is a terminal, so that `pardel solve` draws its progress line: the signal is
  // sent once the line shows that the iteration has started (no timing involved).
  int master = -1;
  const pid_t pid = ::forkpty(&master, nullptr, nullptr, nullptr);
  ASSERT_GE(pid, 0) << std::strerror(errno);
  if (pid == 0) {
    ::execl(PARDEL_CLI_PATH, PARDEL_CLI_PATH, "solve", scene_.c_str(), "--out", out.c_str(), "--threads", "1",
            "--no-plot", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  std::string seen;
  bool signalled = false;
  const std::regex progress("iteration +([0-9]+) +N +1000");
  char buf[4096];
  for (;;) {
    pollfd p{master, POLLIN, 0};
    if (::poll(&p, 1, 120000) <= 0) break;  // a hang: the wait below reports it
    const ssize_t n = ::read(master, buf, sizeof buf);
    if (n <= 0) break;  // EIO once the child has exited
    seen.append(buf, static_cast<std::size_t>(n));
    if (!signalled && std::regex_search(seen, progress)) {
      ::kill(pid, SIGTERM);
      signalled = true;
    }
  }
  int wstatus = 0;
  ASSERT_EQ(::waitpid(pid, &wstatus, 0), pid);
  ::close(master);
  ASSERT_TRUE(signalled) << "no progress line seen:\n" << seen;
  ASSERT_EQ(decode(wstatus), 6) << seen;
  EXPECT_NE(seen.find("checkpoint written; continue with: pardel solve --resume"), std::string::npos) << seen;
  ASSERT_TRUE(fs::exists(out / "checkpoint.json"));
  EXPECT_TRUE(fs::exists(out / "trajectory.csv"));
  EXPECT_TRUE(fs::exists(out / "summary.json"));
  // The message names what stopped the solve (the runtime knows only that on_iteration did).
  EXPECT_NE(read_text(out / "summary.json").find("interrupted by SIGTERM at iteration"), std::string::npos)
      << read_text(out / "summary.json");
  for (const auto& entry : fs::directory_iterator(out))
    EXPECT_EQ(entry.path().filename().string().find(".tmp."), std::string::npos) << "left behind: " << entry.path();
  const Checkpoint c = pardel::app::read_checkpoint(out.string());
  EXPECT_EQ(c.scene_path, fs::absolute(scene_).lexically_normal().string());
  EXPECT_LT(c.state.iteration, 10000);
  EXPECT_EQ(c.state.N, 1000);
  EXPECT_EQ(c.threads, 1);
  // The model it was written by: fuel_nav as compiled into this pardel.
  EXPECT_EQ(c.model_digest, pardel::app::model_digest(*pardel::find_model("fuel_nav")));

  const Outcome resumed = run_pardel({"solve", "--resume", out.string(), "--no-plot", "--quiet"}, dir_ / "resumed.log");
  EXPECT_EQ(resumed.status, 3) << resumed.output;
  EXPECT_EQ(read_text(out / "trajectory.csv"), read_text(dir_ / "reference" / "trajectory.csv"));
  EXPECT_EQ(without_seconds(read_text(out / "convergence.csv")),
            without_seconds(read_text(dir_ / "reference" / "convergence.csv")));
  EXPECT_FALSE(fs::exists(out / "checkpoint.json")) << "a finished solve must not leave a checkpoint";
  // Resuming again finds nothing to resume.
  const Outcome again = run_pardel({"solve", "--resume", out.string(), "--no-plot", "--quiet"}, dir_ / "again.log");
  EXPECT_EQ(again.status, 2);
  EXPECT_NE(again.output.find("checkpoint.json: error: cannot open checkpoint"), std::string::npos) << again.output;
}

TEST_F(CheckpointCli, CheckpointWrittenInProcessResumesToTheReference) {
  ASSERT_EQ(reference_.status, 3) << reference_.output;
  const fs::path out = make_checkpoint("in_process", 25);
  const Outcome resumed = run_pardel({"solve", "--resume", out.string(), "--no-plot", "--quiet", "--threads", "1"},
                                     out / "resume.log");
  EXPECT_EQ(resumed.status, 3) << resumed.output;
  EXPECT_EQ(read_text(out / "trajectory.csv"), read_text(dir_ / "reference" / "trajectory.csv"));
}

TEST_F(CheckpointCli, NestedNewtonResumedOnAnIntermediateLevel) {
  // Newton with coarse-to-fine refinement starts each level from an extrapolation of the two
  // previous levels' solutions; the checkpoint carries the earlier one.
  const fs::path scene = dir_ / "nested.toml";
  write_text(scene,
             "model = \"fuel_nav\"\ndiscretization = \"trapezoid\"\n[grid]\nt0 = 0\nT = 30\nN = 400\n"
             "[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n[guess]\nkind = \"linear\"\n"
             "[solver]\nmethod = \"newton\"\ntol = 1e-10\n[solver.refine]\nstart_N = 25\nfactor = 2\n");
  const Outcome reference = run_pardel({"solve", scene.string(), "--out", (dir_ / "nested_reference").string(),
                                        "--threads", "1", "--no-plot", "--quiet"},
                                       dir_ / "nested_reference.log");
  ASSERT_EQ(reference.status, 0) << reference.output;
  // The first iteration on the third level (N = 100), where two solved levels exist.
  std::istringstream history(read_text(dir_ / "nested_reference" / "convergence.csv"));
  std::string line;
  long K = -1;
  std::getline(history, line);
  while (std::getline(history, line)) {
    long iteration = 0;
    int N = 0;
    if (std::sscanf(line.c_str(), "%ld,%d", &iteration, &N) == 2 && N == 100) {
      K = iteration + 1;
      break;
    }
  }
  ASSERT_GT(K, 0) << "no level N = 100 in the history";
  const fs::path out = make_checkpoint("nested", K, scene);
  const Checkpoint c = pardel::app::read_checkpoint(out.string());
  EXPECT_EQ(c.state.N, 100);
  EXPECT_EQ(c.state.previous_level.N, 50);
  const Outcome resumed = run_pardel({"solve", "--resume", out.string(), "--no-plot", "--quiet"}, out / "resume.log");
  EXPECT_EQ(resumed.status, 0) << resumed.output;
  EXPECT_EQ(read_text(out / "trajectory.csv"), read_text(dir_ / "nested_reference" / "trajectory.csv"));
}

TEST_F(CheckpointCli, TruncatedCheckpointIsRefused) {
  const fs::path out = make_checkpoint("truncated", 3);
  const std::string text = read_text(out / "checkpoint.json");
  write_text(out / "checkpoint.json", text.substr(0, text.size() / 2));
  expect_refused(out, (out / "checkpoint.json").string() + ": error: not a valid checkpoint (JSON parse error at byte");
}

TEST_F(CheckpointCli, EditedNumberFailsTheChecksum) {
  const fs::path out = make_checkpoint("edited", 3);
  std::string text = read_text(out / "checkpoint.json");
  const std::size_t at = text.find("\"q\":[");
  ASSERT_NE(at, std::string::npos);
  const std::size_t digit = text.find_first_of("123456789", at + 10);
  text[digit] = text[digit] == '9' ? '8' : static_cast<char>(text[digit] + 1);
  write_text(out / "checkpoint.json", text);
  expect_refused(out, "checkpoint.json: error: checksum mismatch");
}

TEST_F(CheckpointCli, UnknownFormatVersionIsRefused) {
  const fs::path out = make_checkpoint("version", 3);
  std::string text = read_text(out / "checkpoint.json");
  const std::size_t at = text.find("\"version\": 1");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 12, "\"version\": 99");
  write_text(out / "checkpoint.json", text);
  expect_refused(out, "checkpoint.json: error: checkpoint format version 99 is not supported");
}

TEST_F(CheckpointCli, NotACheckpointIsRefused) {
  const fs::path out = dir_ / "not_a_checkpoint";
  fs::create_directories(out);
  write_text(out / "checkpoint.json", "{\"format\": \"something else\"}");
  expect_refused(out, "checkpoint.json: error: not a pardel checkpoint");
}

TEST_F(CheckpointCli, ChangedSceneIsRefused) {
  const fs::path out = make_checkpoint("changed_scene", 3);
  Checkpoint c = pardel::app::read_checkpoint(out.string());
  const fs::path copy = dir_ / "changed.toml";
  fs::copy_file(scene_, copy, fs::copy_options::overwrite_existing);
  c.scene_path = copy.string();
  pardel::app::write_checkpoint(out.string(), c);
  write_text(copy, read_text(scene_) + "# edited\n");
  expect_refused(out, "the scene file " + copy.string() + " changed since the checkpoint was written");
}

TEST_F(CheckpointCli, BundledModelOfAnotherBuildIsRefused) {
  // The checkpoint of a fuel_nav whose kernels differ from this pardel's (its digest).
  const fs::path out = make_checkpoint("other_build", 3);
  Checkpoint c = pardel::app::read_checkpoint(out.string());
  c.model_digest = "0123456789abcdef";
  pardel::app::write_checkpoint(out.string(), c);
  const std::string before = read_text(out / "checkpoint.json");
  expect_refused(out, (out / "checkpoint.json").string() +
                          ": error: the model fuel_nav changed since the checkpoint was written (its kernels "
                          "compiled into this pardel differ; digest 0123456789abcdef then");
  EXPECT_EQ(read_text(out / "checkpoint.json"), before) << "the refused checkpoint was overwritten";
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

TEST_F(CheckpointCli, MalformedModelDigestIsRefused) {
  const fs::path out = make_checkpoint("malformed_digest", 3);
  Checkpoint c = pardel::app::read_checkpoint(out.string());
  c.model_digest = "not a digest";
  pardel::app::write_checkpoint(out.string(), c);
  expect_refused(out, "checkpoint.json: error: key model.digest = \"not a digest\" is not 16 hex digits");
}

TEST_F(CheckpointCli, CheckpointWithoutAModelDigestIsResumedWithAWarning) {
  // Written before checkpoints recorded the model: resumed as before, with a warning that says so.
  ASSERT_EQ(reference_.status, 3) << reference_.output;
  const fs::path out = make_checkpoint("no_digest", 25);
  Checkpoint c = pardel::app::read_checkpoint(out.string());
  c.model_digest.clear();
  pardel::app::write_checkpoint(out.string(), c);
  EXPECT_EQ(read_text(out / "checkpoint.json").find("digest"), std::string::npos);
  const Outcome resumed = run_pardel({"solve", "--resume", out.string(), "--no-plot", "--quiet", "--threads", "1"},
                                     out / "resume.log");
  EXPECT_EQ(resumed.status, 3) << resumed.output;
  EXPECT_NE(resumed.output.find("checkpoint.json: warning: written by an earlier pardel without the model's digest"),
            std::string::npos)
      << resumed.output;
  EXPECT_EQ(read_text(out / "trajectory.csv"), read_text(dir_ / "reference" / "trajectory.csv"));
}

TEST_F(CheckpointCli, EditedLagFileIsRefused) {
  // A scene naming a .lag file (a copy of fuel_nav's, compiled by the model loader): the model's
  // wind is edited between the interruption and --resume; the scene file itself is unchanged.
  const fs::path lag = dir_ / "fuel_copy.lag";
  fs::copy_file(std::string(PARDEL_SOURCE_DIR) + "/lagrangians/fuel_nav.lag", lag,
                fs::copy_options::overwrite_existing);
  const fs::path scene = dir_ / "lag_scene.toml";
  std::string text = read_text(scene_);
  text.replace(text.find("\"fuel_nav\""), 10, "\"fuel_copy.lag\"");
  write_text(scene, text);
  const fs::path out = make_checkpoint("edited_lag", 3);
  Checkpoint c = pardel::app::read_checkpoint(out.string());
  c.scene_path = scene.string();
  c.scene_hash = pardel::app::fnv1a_hex(read_text(scene));
  c.model_digest = pardel::app::model_digest(*pardel::find_model("fuel_nav"), lag.string());
  pardel::app::write_checkpoint(out.string(), c);
  std::string model = read_text(lag);
  const std::size_t at = model.find("x - 3");
  ASSERT_NE(at, std::string::npos);
  model.replace(at, 5, "x - 2.9");
  write_text(lag, model);
  const Outcome o = run_pardel({"solve", "--resume", out.string(), "--no-plot", "--quiet"}, out / "resume.log");
  if (o.output.find("cannot load .lag files") != std::string::npos) GTEST_SKIP() << "no model loader in this build";
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find((out / "checkpoint.json").string() +
                          ": error: the model fuel_nav changed since the checkpoint was written (its file " +
                          lag.string() + " was edited"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

TEST_F(CheckpointCli, StateOfAnotherGridIsRefused) {
  const fs::path out = make_checkpoint("other_grid", 3);
  Checkpoint c = pardel::app::read_checkpoint(out.string());
  c.overrides = {"grid.N=500"};
  pardel::app::write_checkpoint(out.string(), c);
  expect_refused(out, "resume: refinement level 0 with N = 1000 is not a level of this problem");
}

TEST_F(CheckpointCli, ResumeWithASceneIsAUsageError) {
  const fs::path out = make_checkpoint("with_scene", 3);
  const Outcome o = run_pardel({"solve", scene_.string(), "--resume", out.string()}, out / "log");
  EXPECT_EQ(o.status, 2);
  EXPECT_NE(o.output.find("--resume: give no scene;"), std::string::npos) << o.output;
}

TEST_F(CheckpointCli, WarmStartWithAnotherMethod) {
  // --resume with --set solver.*: the checkpoint's iterate (jacobi-newton, iteration 25) is the
  // start of a Newton solve; the history continues and the summary says it was a warm start.
  const fs::path out = make_checkpoint("warm", 25);
  const Outcome o = run_pardel({"solve", "--resume", out.string(), "--set", "solver.method=newton", "--set",
                                "solver.tol=1e-9", "--no-plot", "--quiet", "--threads", "1"},
                               out / "warm.log");
  EXPECT_EQ(o.status, 0) << o.output;
  const std::string summary = read_text(out / "summary.json");
  EXPECT_NE(summary.find("\"status\": \"converged\""), std::string::npos) << summary;
  EXPECT_NE(summary.find("(warm start from iteration 25 of jacobi-newton at N = 1000)"), std::string::npos) << summary;
  EXPECT_NE(summary.find("\"method\": \"newton\""), std::string::npos) << summary;
  EXPECT_FALSE(fs::exists(out / "checkpoint.json"));
  // The history starts with the interrupted run's first record, and the first records agree.
  const std::string history = read_text(out / "convergence.csv");
  const std::string reference = read_text(dir_ / "reference" / "convergence.csv");
  const auto second_line = [](const std::string& csv) {
    const std::size_t a = csv.find('\n') + 1;
    return without_seconds(csv.substr(a, csv.find('\n', a) - a));
  };
  EXPECT_EQ(second_line(history), second_line(reference));
}

TEST_F(CheckpointCli, ResumeWithAProblemKeyIsAUsageError) {
  const fs::path out = make_checkpoint("problem_key", 3);
  const Outcome o = run_pardel({"solve", "--resume", out.string(), "--set", "grid.N=10"}, out / "log");
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("--resume: only --set solver.KEY=VALUE may change a resumed solve"), std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("'grid.N=10' changes the problem"), std::string::npos) << o.output;
  EXPECT_TRUE(fs::exists(out / "checkpoint.json"));
}

}  // namespace
