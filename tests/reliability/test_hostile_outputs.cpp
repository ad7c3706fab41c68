// Output folders and faults while `pardel solve` writes: --out that is a file, under a file,
// read-only, a symlink, a dangling one, one under a dangling link, a loop of links, a link to a
// file, a FIFO, a device, a name too long (and `pardel sweep --out` a dangling link), outputs that
// are symlinks or directories; two solves
// into one folder at once; SIGKILL and SIGTERM at each rename of the outputs and of the checkpoint
// (injected by a preloaded library, fault_inject.c, so no timing is involved); damaged, foreign,
// swapped and special-file checkpoints beyond those of test_checkpoint_cli.cpp. The promise
// checked: a summary.json, whenever it exists, describes the trajectory.csv and convergence.csv
// beside it (never a mix of two solves), a checkpoint is the old one or the new one, a failure is
// a message with exit status 1 or 2, and nothing crashes or hangs.
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <sys/stat.h>

#include <cerrno>
#include <csignal>
#include <cstring>
#include <functional>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "pardel/app/checkpoint.hpp"
#include "pardel/pardel.hpp"
#include "pardel_process.hpp"
#include "pardel/app/scene.hpp"

namespace {

using namespace reliability;
using pardel::app::Checkpoint;

/** fuel_nav solved by Newton on N intervals (a fraction of a second). */
std::string small_scene(int N) {
  return "model = \"fuel_nav\"\n[grid]\nT = 30\nN = " + std::to_string(N) +
         "\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n[solver]\nmethod = \"newton\"\n";
}

/** fuel_nav under jacobi-newton with a tolerance it cannot reach: iterates for seconds. */
const char* kLongScene =
    "model = \"fuel_nav\"\n[grid]\nT = 30\nN = 1000\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n"
    "[solver]\nmethod = \"jacobi-newton\"\ntol = 1e-15\nmax_iterations = 10000\n";

/** Number of data rows of a CSV text (lines after the header); -1 when the last line is cut. */
long csv_rows(const std::string& csv) {
  if (csv.empty() || csv.back() != '\n') return -1;
  long lines = 0;
  for (char c : csv) lines += c == '\n';
  return lines - 1;
}

/** The N column of convergence.csv's last record. */
long last_history_N(const std::string& csv) {
  const std::size_t end = csv.size() - 1;
  const std::size_t start = csv.rfind('\n', end - 1) + 1;
  const std::string line = csv.substr(start, end - start);
  return std::stol(line.substr(line.find(',') + 1));
}

/**
 * If summary.json exists: it parses, and trajectory.csv (complete, N + 1 rows) and convergence.csv
 * (ending on the same N) are those of the same solve. Returns the summary's N (0 without one).
 */
long expect_consistent_outputs(const fs::path& out) {
  if (!fs::exists(out / "summary.json")) return 0;
  nlohmann::json summary;
  try {
    summary = nlohmann::json::parse(read_text(out / "summary.json"));
  } catch (const std::exception& e) {
    ADD_FAILURE() << "summary.json does not parse: " << e.what();
    return -1;
  }
  const long N = summary.at("N").get<long>();
  EXPECT_TRUE(fs::exists(out / "trajectory.csv"));
  EXPECT_EQ(csv_rows(read_text(out / "trajectory.csv")), N + 1) << "trajectory.csv is not the summary's (N = " << N << ")";
  const std::string history = read_text(out / "convergence.csv");
  EXPECT_GT(csv_rows(history), 0);
  if (csv_rows(history) > 0) EXPECT_EQ(last_history_N(history), N) << "convergence.csv is not the summary's";
  return N;
}

class HostileOutputs : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { dir_ = scratch_folder("pardel_hostile_outputs"); }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static fs::path scene(int N) {
    const fs::path path = dir_ / ("n" + std::to_string(N) + ".toml");
    if (!fs::exists(path)) write_text(path, small_scene(N));
    return path;
  }

  static Outcome solve(int N, const fs::path& out, const std::vector<std::string>& env = {}) {
    return run_pardel({"solve", scene(N).string(), "--out", out.string(), "--no-plot", "--quiet", "--threads", "1"},
                      dir_ / ("solve_" + std::to_string(++runs_) + ".log"), env);
  }

  static std::vector<std::string> fault(const std::string& file, int signal, const char* when = "before",
                                        int sleep_ms = 0) {
    return {std::string("LD_PRELOAD=") + PARDEL_FAULT_INJECT_PATH, "PARDEL_FAULT_RENAME=" + file,
            "PARDEL_FAULT_SIGNAL=" + std::to_string(signal), std::string("PARDEL_FAULT_WHEN=") + when,
            "PARDEL_FAULT_SLEEP_MS=" + std::to_string(sleep_ms)};
  }

  static fs::path dir_;
  static int runs_;
};

fs::path HostileOutputs::dir_;
int HostileOutputs::runs_ = 0;

TEST_F(HostileOutputs, OutIsAFile) {
  write_text(dir_ / "a_file", "keep me");
  const Outcome o = solve(40, dir_ / "a_file");
  EXPECT_EQ(o.status, 1) << o.output;
  const std::string path = (dir_ / "a_file").string();
  EXPECT_NE(o.output.find(path + ": cannot create output folder: " + path + " is a file, not a folder"),
            std::string::npos)
      << o.output;
  EXPECT_EQ(read_text(dir_ / "a_file"), "keep me");
}

TEST_F(HostileOutputs, OutIsUnderAFile) {
  write_text(dir_ / "b_file", "keep me");
  const Outcome o = solve(40, dir_ / "b_file" / "sub");
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("b_file/sub: cannot create output folder: " + (dir_ / "b_file").string() +
                          " is a file, not a folder"),
            std::string::npos)
      << o.output;
  EXPECT_EQ(read_text(dir_ / "b_file"), "keep me");
}

TEST_F(HostileOutputs, OutInAFileSystemNobodyMayWrite) {
  // /proc refuses new entries even to root.
  const Outcome o = run_pardel({"solve", scene(40).string(), "--out", "/proc/version/out", "--no-plot", "--quiet"},
                               dir_ / "proc.log");
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("/proc/version/out: cannot create output folder"), std::string::npos) << o.output;
}

TEST_F(HostileOutputs, OutIsReadOnly) {
  const fs::path out = dir_ / "read_only";
  fs::create_directories(out);
  ::chmod(out.c_str(), 0555);
  write_text(out / "probe", "x");  // succeeds only where permissions do not apply (root)
  if (fs::exists(out / "probe")) {
    fs::remove(out / "probe");
    GTEST_SKIP() << "this user may write into a read-only folder (root); the case cannot be made here";
  }
  const Outcome o = solve(40, out);
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("cannot write: Permission denied"), std::string::npos) << o.output;
  EXPECT_TRUE(fs::is_empty(out));
}

TEST_F(HostileOutputs, OutIsASymlinkToAFolder) {
  fs::create_directories(dir_ / "real");
  fs::create_directory_symlink(dir_ / "real", dir_ / "link");
  const Outcome o = solve(40, dir_ / "link");
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(fs::is_symlink(dir_ / "link"));
  EXPECT_EQ(expect_consistent_outputs(dir_ / "real"), 40);
}

TEST_F(HostileOutputs, OutIsADanglingSymlink) {
  // Said "cannot create output folder: File exists" until the message named the link.
  fs::create_directory_symlink(dir_ / "nowhere", dir_ / "dangling");
  const Outcome o = solve(40, dir_ / "dangling");
  EXPECT_EQ(o.status, 1) << o.output;
  const std::string link = (dir_ / "dangling").string();
  EXPECT_NE(o.output.find(link + ": cannot create output folder: " + link + " is a symbolic link to '" +
                          (dir_ / "nowhere").string() + "', which does not exist"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "nowhere"));
}

TEST_F(HostileOutputs, OutIsUnderADanglingSymlink) {
  fs::create_directory_symlink(dir_ / "nowhere_else", dir_ / "dangling_parent");
  const Outcome o = solve(40, dir_ / "dangling_parent" / "sub");
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("dangling_parent/sub: cannot create output folder: " + (dir_ / "dangling_parent").string() +
                          " is a symbolic link to '" + (dir_ / "nowhere_else").string() + "', which does not exist"),
            std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "nowhere_else"));
}

TEST_F(HostileOutputs, OutIsASymlinkLoop) {
  fs::create_symlink("loop_b", dir_ / "loop_a");
  fs::create_symlink("loop_a", dir_ / "loop_b");
  const Outcome o = solve(40, dir_ / "loop_a");
  EXPECT_FALSE(o.timed_out);
  EXPECT_EQ(o.status, 1) << o.output;
  const std::string link = (dir_ / "loop_a").string();
  EXPECT_NE(o.output.find(link + ": cannot create output folder: " + link +
                          " is a symbolic link to 'loop_b' in a loop of links"),
            std::string::npos)
      << o.output;
}

TEST_F(HostileOutputs, OutIsASymlinkToAFile) {
  write_text(dir_ / "target_file", "keep me");
  fs::create_symlink(dir_ / "target_file", dir_ / "link_to_file");
  const Outcome o = solve(40, dir_ / "link_to_file");
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("link_to_file is a symbolic link to '" + (dir_ / "target_file").string() +
                          "', which is a file, not a folder"),
            std::string::npos)
      << o.output;
  EXPECT_EQ(read_text(dir_ / "target_file"), "keep me");
}

TEST_F(HostileOutputs, OutIsAFifo) {
  // Nothing opens it: a FIFO without a reader would block a writer forever.
  ASSERT_EQ(::mkfifo((dir_ / "a_fifo").c_str(), 0644), 0) << std::strerror(errno);
  const Outcome o = solve(40, dir_ / "a_fifo");
  EXPECT_FALSE(o.timed_out);
  EXPECT_EQ(o.status, 1) << o.output;
  const std::string path = (dir_ / "a_fifo").string();
  EXPECT_NE(o.output.find(path + ": cannot create output folder: " + path + " is a FIFO, not a folder"),
            std::string::npos)
      << o.output;
}

TEST_F(HostileOutputs, OutIsACharacterDevice) {
  const Outcome o = solve(40, "/dev/null");
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("/dev/null: cannot create output folder: /dev/null is a character device, not a folder"),
            std::string::npos)
      << o.output;
}

TEST_F(HostileOutputs, OutNameTooLong) {
  const fs::path out = dir_ / std::string(300, 'n');
  const Outcome o = solve(40, out);
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find(out.string() + ": cannot create output folder: File name too long"), std::string::npos)
      << o.output;
}

TEST_F(HostileOutputs, SweepOutIsADanglingSymlink) {
  // pardel sweep makes its output folder through the same function.
  fs::create_directory_symlink(dir_ / "sweep_nowhere", dir_ / "sweep_dangling");
  write_text(dir_ / "one.sweep.toml", "scene = \"n40.toml\"\n");
  scene(40);
  const Outcome o = run_pardel({"sweep", (dir_ / "one.sweep.toml").string(), "--out", (dir_ / "sweep_dangling").string(),
                                "--no-plot", "--quiet", "--threads", "1"},
                               dir_ / "sweep_dangling.log");
  EXPECT_EQ(o.status, 1) << o.output;
  const std::string link = (dir_ / "sweep_dangling").string();
  EXPECT_NE(o.output.find(link + ": cannot create output folder: " + link + " is a symbolic link to '" +
                          (dir_ / "sweep_nowhere").string() + "', which does not exist"),
            std::string::npos)
      << o.output;
}

TEST_F(HostileOutputs, SymlinkedOutputIsReplacedNotFollowed) {
  const fs::path out = dir_ / "symlinked_summary";
  fs::create_directories(out);
  write_text(dir_ / "outside.txt", "not pardel's");
  fs::create_symlink(dir_ / "outside.txt", out / "summary.json");
  const Outcome o = solve(40, out);
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(read_text(dir_ / "outside.txt"), "not pardel's");
  EXPECT_FALSE(fs::is_symlink(out / "summary.json"));
  EXPECT_EQ(expect_consistent_outputs(out), 40);
}

TEST_F(HostileOutputs, OutputNameTakenByAFolder) {
  const fs::path out = dir_ / "folder_in_the_way";
  ASSERT_EQ(solve(40, out).status, 0);
  fs::remove(out / "trajectory.csv");
  fs::create_directories(out / "trajectory.csv");
  const Outcome o = solve(60, out);
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_NE(o.output.find("trajectory.csv: cannot rename into place: Is a directory"), std::string::npos) << o.output;
  EXPECT_FALSE(fs::exists(out / "summary.json")) << "a summary.json without its trajectory.csv";
  EXPECT_TRUE(temporary_files(out).empty());
}

TEST_F(HostileOutputs, TwoSolvesIntoOneFolderAtOnce) {
  // The first solve pauses between two of its renames (before convergence.csv) while the second
  // one runs to its end: the folder must end with one solve's complete set.
  const fs::path out = dir_ / "shared";
  fs::create_directories(out);
  const pid_t first = start_pardel({"solve", scene(40).string(), "--out", out.string(), "--no-plot", "--quiet",
                                    "--threads", "1"},
                                   dir_ / "shared_first.log", fault("convergence.csv", 0, "before", 1500));
  // Wait until the first solve is inside its pause (its trajectory.csv is in place).
  for (int i = 0; i < 6000 && csv_rows(read_text(out / "trajectory.csv")) != 41; ++i) ::usleep(5000);
  const Outcome second = solve(60, out);
  const Outcome first_outcome = finish_pardel(first, dir_ / "shared_first.log");
  EXPECT_EQ(first_outcome.status, 0) << first_outcome.output;
  EXPECT_EQ(second.status, 0) << second.output;
  EXPECT_GT(expect_consistent_outputs(out), 0);
  EXPECT_TRUE(temporary_files(out).empty());
}

TEST_F(HostileOutputs, FourSolvesIntoOneFolderAtOnce) {
  const fs::path out = dir_ / "shared4";
  fs::create_directories(out);
  std::vector<pid_t> pids;
  for (int N : {30, 40, 50, 60})
    pids.push_back(start_pardel({"solve", scene(N).string(), "--out", out.string(), "--no-plot", "--quiet", "--threads",
                                 "1"},
                                dir_ / ("shared4_" + std::to_string(N) + ".log")));
  for (std::size_t i = 0; i < pids.size(); ++i) {
    const Outcome o = finish_pardel(pids[i], dir_ / ("shared4_" + std::to_string(30 + 10 * i) + ".log"));
    EXPECT_EQ(o.status, 0) << o.output;
  }
  EXPECT_GT(expect_consistent_outputs(out), 0);
  EXPECT_TRUE(temporary_files(out).empty());
}

/** A signal at one rename of the outputs of a solve that replaces an earlier one. */
struct KillPoint {
  const char* file;
  const char* when;
  int signal;
};

void PrintTo(const KillPoint& k, std::ostream* os) { *os << k.when << " " << k.file << " " << k.signal; }

class KilledWhileWriting : public HostileOutputs, public ::testing::WithParamInterface<KillPoint> {};

TEST_P(KilledWhileWriting, LeavesTheOldSetOrTheNewOneNeverAMix) {
  const KillPoint& k = GetParam();
  const fs::path out = dir_ / (std::string("killed_") + k.when + "_" + k.file + "_" + std::to_string(k.signal));
  ASSERT_EQ(solve(40, out).status, 0);  // the old set
  const Outcome killed = solve(60, out, fault(k.file, k.signal, k.when));
  EXPECT_EQ(killed.status, 128 + k.signal) << killed.output;
  const long N = expect_consistent_outputs(out);
  EXPECT_TRUE(N == 0 || N == 40 || N == 60) << N;
  // The next solve into the folder completes and removes what the killed one left behind.
  const Outcome again = solve(60, out);
  EXPECT_EQ(again.status, 0) << again.output;
  EXPECT_EQ(expect_consistent_outputs(out), 60);
  EXPECT_TRUE(temporary_files(out).empty()) << temporary_files(out).front();
}

INSTANTIATE_TEST_SUITE_P(
    EachRename, KilledWhileWriting,
    ::testing::Values(KillPoint{"trajectory.csv", "before", SIGKILL}, KillPoint{"convergence.csv", "before", SIGKILL},
                      KillPoint{"summary.json", "before", SIGKILL}, KillPoint{"summary.json", "after", SIGKILL},
                      KillPoint{"trajectory.csv", "before", SIGTERM}, KillPoint{"convergence.csv", "before", SIGTERM},
                      KillPoint{"summary.json", "before", SIGTERM}, KillPoint{"summary.json", "after", SIGTERM}),
    [](const ::testing::TestParamInfo<KillPoint>& info) {
      return std::string(info.param.when) + "_" +
             (info.param.file[0] == 't' ? "trajectory" : info.param.file[0] == 'c' ? "convergence" : "summary") +
             (info.param.signal == SIGKILL ? "_sigkill" : "_sigterm");
    });

// ---------------------------------------------------------------------------------------------
// Checkpoints

/** Runs pardel with stderr on a terminal (so that it draws its progress line) and sends SIGTERM
 *  once the line shows the iteration; returns the exit status (128 + signal if killed). */
int interrupt_once_iterating(const std::vector<std::string>& args, const std::vector<std::string>& env,
                             std::string* seen) {
  int master = -1;
  const pid_t pid = ::forkpty(&master, nullptr, nullptr, nullptr);
  if (pid < 0) return -1;
  if (pid == 0) {
    for (const std::string& e : env) {
      const auto eq = e.find('=');
      ::setenv(e.substr(0, eq).c_str(), e.substr(eq + 1).c_str(), 1);
    }
    std::vector<char*> argv = {const_cast<char*>(PARDEL_CLI_PATH)};
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    ::execv(PARDEL_CLI_PATH, argv.data());
    ::_exit(127);
  }
  bool signalled = false;
  const std::regex progress("iteration +[0-9]+ +N +1000");
  char buf[4096];
  for (;;) {
    pollfd p{master, POLLIN, 0};
    if (::poll(&p, 1, 60000) <= 0) {  // a hang
      ::kill(pid, SIGKILL);
      break;
    }
    const ssize_t n = ::read(master, buf, sizeof buf);
    if (n <= 0) break;
    seen->append(buf, static_cast<std::size_t>(n));
    if (!signalled && std::regex_search(*seen, progress)) {
      ::kill(pid, SIGTERM);
      signalled = true;
    }
  }
  int wstatus = 0;
  ::waitpid(pid, &wstatus, 0);
  ::close(master);
  if (!signalled) return -2;
  return WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
}

class HostileCheckpoint : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = scratch_folder("pardel_hostile_checkpoint");
    scene_ = dir_ / "long.toml";
    write_text(scene_, kLongScene);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  /** A valid checkpoint of `scene_path` at iteration K, written in-process (no signal). */
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
    c.state = summary.state;
    const fs::path out = dir_ / name;
    fs::create_directories(out);
    pardel::app::write_checkpoint(out.string(), c);
    return out;
  }

  /** Edits the checkpoint's body and writes it back with a matching checksum. */
  static void edit_body(const fs::path& out, const std::function<void(nlohmann::json&)>& edit) {
    nlohmann::json file = nlohmann::json::parse(read_text(out / "checkpoint.json"));
    edit(file["body"]);
    file["checksum"] = pardel::app::fnv1a_hex(file["body"].dump());
    write_text(out / "checkpoint.json", file.dump());
  }

  static Outcome resume(const fs::path& out) {
    return run_pardel({"solve", "--resume", out.string(), "--no-plot", "--quiet", "--threads", "1"},
                      out.string() + ".log");
  }

  static void expect_refused(const fs::path& out, const std::string& expected) {
    const std::string before = fs::is_regular_file(out / "checkpoint.json") ? read_text(out / "checkpoint.json") : "";
    const Outcome o = resume(out);
    EXPECT_FALSE(o.timed_out);
    EXPECT_EQ(o.status, 2) << o.output;
    const std::string full = (out / "checkpoint.json").string() + ": error: " + expected;
    EXPECT_NE(o.output.find(full), std::string::npos) << "expected: " << full << "\ngot: " << o.output;
    EXPECT_FALSE(fs::exists(out / "summary.json")) << "a refused checkpoint wrote outputs";
    if (!before.empty()) EXPECT_EQ(read_text(out / "checkpoint.json"), before) << "a refused checkpoint was changed";
  }

  static fs::path dir_, scene_;
};

fs::path HostileCheckpoint::dir_, HostileCheckpoint::scene_;

TEST_F(HostileCheckpoint, KilledWhileWritingTheCheckpoint) {
  // SIGTERM stops the solve; SIGKILL comes as its checkpoint is renamed into place.
  const fs::path out = dir_ / "killed_first";
  std::string seen;
  const int status = interrupt_once_iterating(
      {"solve", scene_.string(), "--out", out.string(), "--threads", "1", "--no-plot"},
      {std::string("LD_PRELOAD=") + PARDEL_FAULT_INJECT_PATH, "PARDEL_FAULT_RENAME=checkpoint.json",
       "PARDEL_FAULT_SIGNAL=9"},
      &seen);
  ASSERT_EQ(status, 128 + SIGKILL) << seen;
  EXPECT_FALSE(fs::exists(out / "checkpoint.json"));
  EXPECT_EQ(expect_consistent_outputs(out), 1000);
  EXPECT_NE(read_text(out / "summary.json").find("\"status\": \"interrupted\""), std::string::npos);
  const Outcome o = resume(out);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("checkpoint.json: error: cannot open checkpoint"), std::string::npos) << o.output;
}

TEST_F(HostileCheckpoint, KilledWhileReplacingACheckpointKeepsTheOldOne) {
  const fs::path out = make_checkpoint("killed_replace", 3);
  const std::string old_checkpoint = read_text(out / "checkpoint.json");
  std::string seen;
  const int status = interrupt_once_iterating(
      {"solve", "--resume", out.string(), "--threads", "1", "--no-plot"},
      {std::string("LD_PRELOAD=") + PARDEL_FAULT_INJECT_PATH, "PARDEL_FAULT_RENAME=checkpoint.json",
       "PARDEL_FAULT_SIGNAL=9"},
      &seen);
  ASSERT_EQ(status, 128 + SIGKILL) << seen;
  EXPECT_EQ(read_text(out / "checkpoint.json"), old_checkpoint);
  EXPECT_NO_THROW(pardel::app::read_checkpoint(out.string()));
  EXPECT_EQ(expect_consistent_outputs(out), 1000);
}

TEST_F(HostileCheckpoint, EmptyFile) {
  const fs::path out = dir_ / "empty";
  fs::create_directories(out);
  write_text(out / "checkpoint.json", "");
  expect_refused(out, "not a valid checkpoint (JSON parse error at byte 1)");
}

TEST_F(HostileCheckpoint, BinaryGarbage) {
  const fs::path out = dir_ / "garbage";
  fs::create_directories(out);
  std::string bytes;
  for (int i = 0; i < 4096; ++i) bytes += static_cast<char>((i * 7919) % 256);
  write_text(out / "checkpoint.json", bytes);
  expect_refused(out, "not a valid checkpoint (JSON parse error at byte");
}

TEST_F(HostileCheckpoint, TrailingGarbageAfterAValidCheckpoint) {
  const fs::path out = make_checkpoint("trailing", 3);
  write_text(out / "checkpoint.json", read_text(out / "checkpoint.json") + "}{");
  expect_refused(out, "not a valid checkpoint (JSON parse error at byte");
}

TEST_F(HostileCheckpoint, TopLevelArray) {
  const fs::path out = dir_ / "array";
  fs::create_directories(out);
  write_text(out / "checkpoint.json", "[1, 2, 3]");
  expect_refused(out, "not a checkpoint (the top level is not a JSON object)");
}

TEST_F(HostileCheckpoint, NestedTwoHundredThousandLevels) {
  // Crashed pardel (stack overflow while the body was dumped for its checksum).
  const fs::path out = dir_ / "deep";
  fs::create_directories(out);
  write_text(out / "checkpoint.json", "{\"format\": \"pardel-checkpoint\", \"version\": 1, \"checksum\": \"0\", \"body\": " +
                                          std::string(200000, '[') + std::string(200000, ']') + "}");
  expect_refused(out, "not a pardel checkpoint (JSON nested more than 64 levels deep)");
}

TEST_F(HostileCheckpoint, CheckpointIsAFolder) {
  const fs::path out = dir_ / "folder";
  fs::create_directories(out / "checkpoint.json");
  expect_refused(out, "is a directory, not a checkpoint");
}

TEST_F(HostileCheckpoint, CheckpointIsAFifo) {
  // Opening a FIFO without a writer blocks forever: opened without waiting and refused.
  const fs::path out = dir_ / "fifo";
  fs::create_directories(out);
  ASSERT_EQ(::mkfifo((out / "checkpoint.json").c_str(), 0644), 0) << std::strerror(errno);
  expect_refused(out, "is a FIFO, not a regular file");
}

TEST_F(HostileCheckpoint, ForeignModelWithAValidChecksum) {
  const fs::path out = make_checkpoint("foreign_model", 3);
  edit_body(out, [](nlohmann::json& body) { body["model"]["name"] = "harmonic"; });
  expect_refused(out, "the checkpoint is of model harmonic (dim 2), the scene now resolves to fuel_nav (dim 2)");
}

TEST_F(HostileCheckpoint, SceneFileGone) {
  const fs::path scene = dir_ / "gone.toml";
  write_text(scene, kLongScene);
  const fs::path out = make_checkpoint("scene_gone", 3, scene);
  fs::remove(scene);
  const Outcome o = resume(out);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find(scene.string() + ": error: cannot open scene file"), std::string::npos) << o.output;
  EXPECT_TRUE(fs::exists(out / "checkpoint.json"));
}

TEST_F(HostileCheckpoint, HugeNWithoutItsValues) {
  const fs::path out = make_checkpoint("huge_N", 3);
  edit_body(out, [](nlohmann::json& body) { body["state"]["N"] = 2147483647; });
  expect_refused(out, "key state.t has 1001 values; N = 2147483647 needs 2147483648");
}

TEST_F(HostileCheckpoint, StateOfAnotherDimension) {
  const fs::path out = make_checkpoint("other_dim", 3);
  edit_body(out, [](nlohmann::json& body) { body["state"]["dim"] = 3; });
  expect_refused(out, "key state.dim = 3 differs from model.dim = 2");
}

TEST_F(HostileCheckpoint, UnknownMethod) {
  const fs::path out = make_checkpoint("unknown_method", 3);
  edit_body(out, [](nlohmann::json& body) { body["state"]["method"] = "newtonian"; });
  expect_refused(out, "key state.method: unknown method 'newtonian'");
}

TEST_F(HostileCheckpoint, NanInTheIterateWithAValidChecksum) {
  const fs::path out = make_checkpoint("nan_iterate", 3);
  edit_body(out, [](nlohmann::json& body) { body["state"]["q"][10] = "nan"; });
  expect_refused(out, "resume:");
}

TEST_F(HostileCheckpoint, WrongTypeOfAKey) {
  const fs::path out = make_checkpoint("wrong_type", 3);
  edit_body(out, [](nlohmann::json& body) { body["state"]["iteration"] = "three"; });
  expect_refused(out, "key state.iteration must be an integer");
}

TEST_F(HostileCheckpoint, SwappedCheckpointsContinueTheirOwnScenes) {
  // Each checkpoint records its scene: swapped between two folders, each resumes the solve it
  // belongs to, and the folder's outputs then describe that solve.
  const fs::path scene_a = dir_ / "swap_a.toml", scene_b = dir_ / "swap_b.toml";
  write_text(scene_a, std::string(kLongScene).replace(std::string(kLongScene).find("10000"), 5, "40"));
  write_text(scene_b, small_scene(50));
  const fs::path out_a = make_checkpoint("swap_a", 3, scene_a);
  const fs::path out_b = dir_ / "swap_b";
  {
    Checkpoint c;
    const pardel::app::Scene scene = pardel::app::load_scene(
        scene_b.string(), {}, [](const std::string& n) { return pardel::find_model(n); });
    pardel::Options options = scene.options;
    options.on_iteration = [](const pardel::IterationRecord& r) { return r.iteration < 1; };
    pardel::Trajectory trajectory = pardel::app::make_initial_guess(scene);
    c.state = pardel::solve(scene.problem, options, trajectory).state;
    ASSERT_TRUE(c.state.valid);
    c.scene_path = scene_b.string();
    c.scene_hash = pardel::app::fnv1a_hex(read_text(scene_b));
    c.model = "fuel_nav";
    c.dim = 2;
    fs::create_directories(out_b);
    pardel::app::write_checkpoint(out_b.string(), c);
  }
  const std::string a = read_text(out_a / "checkpoint.json");
  write_text(out_a / "checkpoint.json", read_text(out_b / "checkpoint.json"));
  write_text(out_b / "checkpoint.json", a);
  const Outcome resumed_a = resume(out_a), resumed_b = resume(out_b);
  EXPECT_EQ(resumed_a.status, 0) << resumed_a.output;  // scene b: Newton, converges
  EXPECT_EQ(resumed_b.status, 3) << resumed_b.output;  // scene a: max_iterations
  EXPECT_EQ(expect_consistent_outputs(out_a), 50);
  EXPECT_EQ(expect_consistent_outputs(out_b), 1000);
  EXPECT_NE(read_text(out_a / "summary.json").find(scene_b.string()), std::string::npos);
  EXPECT_NE(read_text(out_b / "summary.json").find(scene_a.string()), std::string::npos);
}

}  // namespace
