// Special files, names and encodings given to the built `pardel` and `pardel-gen` as a user would:
// a FIFO, /dev/zero, a 1 GiB sparse file (4 GiB for a checkpoint, whose limit is 2 GiB), a folder,
// a socket, /dev/null and a link to a FIFO in place of a scene, a sweep file, its base scene, a
// .lag file (pardel kernels, a scene's model, pardel-gen), a trajectory (pardel check
// --trajectory), a CSV guess and a checkpoint. Each is refused within seconds with exit status 2
// (pardel-gen: 1) and a message naming the path and what it is, the process staying under 256 MiB (nothing read
// before the check). Then names: a coordinate named k (trajectory.csv's header is k,t,k,...) read
// by pardel check and as a CSV guess with the right values, duplicate columns refused at
// FILE:1:COL; and paths that are not UTF-8: a scene, an output folder, a sweep, a trajectory and a
// .lag file, whose solves complete with valid JSON; an interrupted solve of such a scene resumes.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <thread>
#include <vector>

#include "pardel_process.hpp"

namespace {

using namespace reliability;

/** A finished run with its peak resident memory. */
struct Measured {
  Outcome outcome;
  long max_rss_kib = 0;  ///< ru_maxrss of the process
  double seconds = 0;
};

/** Runs `program` with `args` (killed after `limit_s`), measuring its peak memory through wait4. */
Measured run_measured(const std::string& program, const std::vector<std::string>& args, const fs::path& log,
                      const std::vector<std::string>& env, int limit_s = 30) {
  Measured m;
  const auto start = std::chrono::steady_clock::now();
  const pid_t pid = start_program(program, args, log, env);
  const auto deadline = start + std::chrono::seconds(limit_s);
  int wstatus = 0;
  struct rusage usage {};
  for (;;) {
    const pid_t r = ::wait4(pid, &wstatus, WNOHANG, &usage);
    if (r == pid) break;
    if (r < 0) return m;
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(-pid, SIGKILL);
      ::wait4(pid, &wstatus, 0, &usage);
      m.outcome.timed_out = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  m.max_rss_kib = usage.ru_maxrss;
  m.outcome.status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
  m.outcome.output = read_text(log);
  return m;
}

/** A JSON file parsed strictly (nlohmann refuses text that is not UTF-8); null when it is not JSON. */
nlohmann::json parse_json_file(const fs::path& path) {
  try {
    return nlohmann::json::parse(read_text(path));
  } catch (const nlohmann::json::exception&) {
    return nlohmann::json();
  }
}

const std::string kScene = "model = \"fuel_nav\"\n[grid]\nT = 30\nN = 20\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n";

/** A free particle in the plane whose first coordinate is named k (the name of trajectory.csv's
 *  node index column): L = (k'^2 + y'^2)/2, so the action of a straight line is T |v|^2 / 2. */
const std::string kCoordK = "model coord_k\ncoords k y\nL = (k'^2 + y'^2)/2\ndiscretizations trapezoid\n";

// ---------------------------------------------------------------------------------------------
// Special files in place of every file pardel reads

/** What stands where a file should be. */
enum class Kind { fifo, folder, dev_zero, sparse, sparse_4g, socket, dev_null, link_to_fifo };

/** Which reader is given it, and how. */
enum class Reader { scene_solve, scene_check, sweep, sweep_base_scene, lag_kernels, lag_in_scene, lag_gen, trajectory,
                    guess, checkpoint };

struct SpecialCase {
  const char* name;
  Reader reader;
  Kind kind;
};

void PrintTo(const SpecialCase& c, std::ostream* os) { *os << c.name; }

/** The part of the message that says what the file is. */
std::string reason_of(Kind kind) {
  switch (kind) {
    case Kind::fifo:
    case Kind::link_to_fifo: return "is a FIFO, not a regular file";
    case Kind::folder: return "is a directory, not a ";
    case Kind::dev_zero:
    case Kind::dev_null: return "is a character device, not a regular file";
    case Kind::sparse: return "is 1073741824 bytes (1 GiB), more than the limit of ";
    case Kind::sparse_4g: return "is 4294967296 bytes (4 GiB), more than the limit of ";
    case Kind::socket: return "is a socket, not a regular file";
  }
  return "";
}

class SpecialFile : public ::testing::TestWithParam<SpecialCase> {
 protected:
  static void SetUpTestSuite() { cache_ = scratch_folder("pardel_special_cache"); }
  static void TearDownTestSuite() { fs::remove_all(cache_); }
  void SetUp() override { dir_ = scratch_folder("pardel_special_file"); }
  void TearDown() override {
    if (socket_ >= 0) ::close(socket_);
    fs::remove_all(dir_);
  }

  /** Makes the special file `kind` under `name` in the scratch folder (or returns a device). */
  fs::path make(Kind kind, const std::string& name) {
    const fs::path path = dir_ / name;
    switch (kind) {
      case Kind::fifo:
        EXPECT_EQ(::mkfifo(path.c_str(), 0644), 0) << std::strerror(errno);
        return path;
      case Kind::link_to_fifo:
        EXPECT_EQ(::mkfifo((dir_ / "the_fifo").c_str(), 0644), 0) << std::strerror(errno);
        fs::create_symlink(dir_ / "the_fifo", path);
        return path;
      case Kind::folder: fs::create_directories(path); return path;
      case Kind::dev_zero: fs::create_symlink("/dev/zero", path); return path;
      case Kind::dev_null: fs::create_symlink("/dev/null", path); return path;
      case Kind::sparse:
      case Kind::sparse_4g: {
        write_text(path, "");
        fs::resize_file(path, std::uintmax_t{1} << (kind == Kind::sparse ? 30 : 32));  // a hole: no disk space used
        return path;
      }
      case Kind::socket: {
        socket_ = ::socket(AF_UNIX, SOCK_STREAM, 0);
        sockaddr_un address{};
        address.sun_family = AF_UNIX;
        std::strncpy(address.sun_path, path.c_str(), sizeof address.sun_path - 1);
        EXPECT_EQ(::bind(socket_, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0)
            << std::strerror(errno);
        return path;
      }
    }
    return path;
  }

  fs::path dir_;
  static fs::path cache_;
  int socket_ = -1;
};

fs::path SpecialFile::cache_;

TEST_P(SpecialFile, IsRefusedQuicklyByName) {
  const SpecialCase& c = GetParam();
  const fs::path out = dir_ / "out";
  std::string program = PARDEL_CLI_PATH;
  std::vector<std::string> args;
  fs::path bad;
  std::string prefix;  // what precedes "PATH: error: " (or "PATH:1:1: error: ")
  std::string located = ": error: ";
  switch (c.reader) {
    case Reader::scene_solve:
      bad = make(c.kind, "scene.toml");
      args = {"solve", bad.string(), "--out", out.string(), "--no-plot", "--quiet"};
      break;
    case Reader::scene_check:
      bad = make(c.kind, "scene.toml");
      args = {"check", bad.string()};
      break;
    case Reader::sweep:
      bad = make(c.kind, "sweep.toml");
      args = {"sweep", bad.string(), "--out", out.string(), "--no-plot", "--quiet"};
      break;
    case Reader::sweep_base_scene:
      bad = make(c.kind, "base.toml");
      write_text(dir_ / "sweep.toml", "scene = \"base.toml\"\n");
      args = {"sweep", (dir_ / "sweep.toml").string(), "--out", out.string(), "--no-plot", "--quiet"};
      prefix = (dir_ / "sweep.toml").string() + ":1:9: error: scene '";
      located = "' ";
      break;
    case Reader::lag_kernels:
      bad = make(c.kind, "model.lag");
      args = {"kernels", "--model", bad.string(), "--disc", "trapezoid", "--h", "0.5", "--t0", "0", "--t1", "0.5",
              "--q0", "1", "--q1", "1"};
      located = ":1:1: error: ";  // a .lag diagnostic is located, as pardel-gen's
      break;
    case Reader::lag_in_scene:
      bad = make(c.kind, "model.lag");
      write_text(dir_ / "s.toml", "model = \"model.lag\"\n[grid]\nT = 1\nN = 10\n[boundary]\nq0 = [0]\nqN = [1]\n");
      args = {"solve", (dir_ / "s.toml").string(), "--out", out.string(), "--no-plot", "--quiet"};
      located = ":1:1: error: ";
      break;
    case Reader::lag_gen:
      bad = make(c.kind, "model.lag");
      program = PARDEL_GEN_PATH;
      args = {bad.string(), "-o", (dir_ / "ir.json").string()};
      located = ":1:1: error: ";
      break;
    case Reader::trajectory:
      bad = make(c.kind, "trajectory.csv");
      write_text(dir_ / "s.toml", kScene);
      args = {"check", (dir_ / "s.toml").string(), "--trajectory", bad.string()};
      prefix = "--trajectory: ";
      break;
    case Reader::guess:
      bad = make(c.kind, "guess.csv");
      write_text(dir_ / "s.toml", kScene + "[guess]\nkind = \"csv\"\npath = \"guess.csv\"\n");
      args = {"solve", (dir_ / "s.toml").string(), "--out", out.string(), "--no-plot", "--quiet"};
      prefix = (dir_ / "s.toml").string() + ":10:8: error: guess.path: '";
      located = "' ";
      break;
    case Reader::checkpoint:
      fs::create_directories(out);
      bad = make(c.kind, "out/checkpoint.json");
      args = {"solve", "--resume", out.string(), "--no-plot", "--quiet"};
      break;
  }
  const Measured m = run_measured(program, args, dir_ / "log", {"PARDEL_CACHE_DIR=" + cache_.string()});
  const Outcome& o = m.outcome;
  EXPECT_FALSE(o.timed_out) << "hung on " << bad;
  EXPECT_LT(m.seconds, 10.0);
  EXPECT_EQ(o.status, c.reader == Reader::lag_gen ? 1 : 2) << o.output;  // pardel-gen: 1 for a refused .lag
  const std::string expected = prefix + bad.string() + located + reason_of(c.kind);
  EXPECT_NE(o.output.find(expected), std::string::npos) << "expected: " << expected << "\ngot: " << o.output;
  EXPECT_LT(m.max_rss_kib, 256 * 1024) << "read into memory before its check";
  if (c.reader != Reader::checkpoint) EXPECT_FALSE(fs::exists(out)) << "a refused input created its output folder";
}

#define SPECIAL(reader, kind) SpecialCase{#reader "_" #kind, Reader::reader, Kind::kind}

INSTANTIATE_TEST_SUITE_P(
    EveryReader, SpecialFile,
    ::testing::Values(
        SPECIAL(scene_solve, fifo), SPECIAL(scene_solve, folder), SPECIAL(scene_solve, dev_zero),
        SPECIAL(scene_solve, sparse), SPECIAL(scene_solve, socket), SPECIAL(scene_solve, link_to_fifo),
        SPECIAL(scene_check, fifo), SPECIAL(scene_check, dev_zero), SPECIAL(scene_check, sparse),
        SPECIAL(sweep, fifo), SPECIAL(sweep, folder), SPECIAL(sweep, dev_zero), SPECIAL(sweep, sparse),
        SPECIAL(sweep_base_scene, fifo), SPECIAL(sweep_base_scene, folder), SPECIAL(sweep_base_scene, dev_zero),
        SPECIAL(sweep_base_scene, sparse),
        SPECIAL(lag_kernels, fifo), SPECIAL(lag_kernels, folder), SPECIAL(lag_kernels, dev_zero),
        SPECIAL(lag_kernels, sparse), SPECIAL(lag_kernels, dev_null),
        SPECIAL(lag_in_scene, fifo), SPECIAL(lag_in_scene, dev_zero), SPECIAL(lag_in_scene, sparse),
        SPECIAL(lag_gen, fifo), SPECIAL(lag_gen, folder), SPECIAL(lag_gen, dev_zero), SPECIAL(lag_gen, sparse),
        SPECIAL(lag_gen, socket),
        SPECIAL(trajectory, fifo), SPECIAL(trajectory, folder), SPECIAL(trajectory, dev_zero),
        SPECIAL(trajectory, sparse), SPECIAL(trajectory, dev_null),
        SPECIAL(guess, fifo), SPECIAL(guess, folder), SPECIAL(guess, dev_zero), SPECIAL(guess, sparse),
        SPECIAL(guess, link_to_fifo),
        SPECIAL(checkpoint, dev_zero), SPECIAL(checkpoint, sparse_4g), SPECIAL(checkpoint, link_to_fifo)),
    [](const ::testing::TestParamInfo<SpecialCase>& info) { return std::string(info.param.name); });

// ---------------------------------------------------------------------------------------------
// Column names of trajectory and guess files

class Columns : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = scratch_folder("pardel_columns");
    write_text(dir_ / "coord_k.lag", kCoordK);
    // From (0, 0) to (3, 2) in T = 1 on N = 4 nodes: the straight line's action is (9 + 4)/2.
    write_text(dir_ / "k.toml",
               "model = \"coord_k.lag\"\n[grid]\nT = 1\nN = 4\n[boundary]\nq0 = [0, 0]\nqN = [3, 2]\n");
    write_text(dir_ / "nav.toml", kScene);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static Outcome pardel(const std::vector<std::string>& args, const std::string& log) {
    return run_pardel(args, dir_ / log, {"PARDEL_CACHE_DIR=" + (dir_ / "cache").string()}, 120);
  }
  /** pardel check --json of `scene` (with --trajectory `csv` when given), parsed; null on failure. */
  static nlohmann::json check(const std::string& scene, const std::string& csv, Outcome* o) {
    std::vector<std::string> args = {"check", (dir_ / scene).string(), "--json"};
    if (!csv.empty()) args.insert(args.end(), {"--trajectory", (dir_ / csv).string()});
    std::string log = scene + "_" + csv + ".log";
    std::replace(log.begin(), log.end(), '/', '_');
    *o = pardel(args, log);
    const std::size_t brace = o->output.find('{');
    if (o->status != 0 || brace == std::string::npos) return nlohmann::json();
    try {
      return nlohmann::json::parse(o->output.substr(brace));
    } catch (const nlohmann::json::exception&) {
      return nlohmann::json();
    }
  }
  /** The straight line from (0, 0) to (3, 2) in t in [0, 1], N = 4, with `header` and a row per
   *  node given by `row(k, t, q_k, y)`. */
  template <class Row>
  static void write_line(const std::string& name, const std::string& header, Row row) {
    std::string text = header + "\n";
    for (int k = 0; k <= 4; ++k) text += row(k, k / 4.0, 3 * k / 4.0, 2 * k / 4.0) + "\n";
    write_text(dir_ / name, text);
  }
  static void expect_refused(const std::string& scene, const std::string& csv, const std::string& message) {
    Outcome o;
    check(scene, csv, &o);
    EXPECT_EQ(o.status, 2) << o.output;
    const std::string expected = (dir_ / csv).string() + ":" + message;
    EXPECT_NE(o.output.find(expected), std::string::npos) << "expected: " << expected << "\ngot: " << o.output;
  }
  static fs::path dir_;
};

fs::path Columns::dir_;

/** 17 significant digits. */
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

const double kLineAction = (9.0 + 4.0) / 2;  // T |v|^2 / 2 with v = (3, 2), T = 1

TEST_F(Columns, CoordinateNamedKIsReadByCheck) {
  // The header pardel writes for coord_k: the node index k, t, then the coordinate k.
  write_line("k_written.csv", "k,t,k,y,k',y'", [](int k, double t, double q, double y) {
    return std::to_string(k) + "," + num(t) + "," + num(q) + "," + num(y) + ",3,2";
  });
  Outcome o;
  const nlohmann::json j = check("k.toml", "k_written.csv", &o);
  ASSERT_TRUE(j.is_object()) << o.output;
  EXPECT_NEAR(j["action"].get<double>(), kLineAction, 1e-12) << o.output;  // the index read as k gives 10
  EXPECT_LT(j["residual"].get<double>(), 1e-12);
}

TEST_F(Columns, CoordinateNamedKAsACsvGuess) {
  write_line("k_guess.csv", "k,t,k,y", [](int k, double t, double q, double y) {
    return std::to_string(k) + "," + num(t) + "," + num(q) + "," + num(y);
  });
  write_text(dir_ / "k_guess.toml", read_text(dir_ / "k.toml") + "[guess]\nkind = \"csv\"\npath = \"k_guess.csv\"\n");
  Outcome o;
  const nlohmann::json j = check("k_guess.toml", "", &o);
  ASSERT_TRUE(j.is_object()) << o.output;
  EXPECT_NEAR(j["action"].get<double>(), kLineAction, 1e-12) << o.output;
}

TEST_F(Columns, CoordinateNamedKBeforeTheIndexOrder) {
  // Columns in another order: the first k is the node index, the second the coordinate.
  write_line("k_reordered.csv", "t,k,y,k", [](int k, double t, double q, double y) {
    return num(t) + "," + std::to_string(k) + "," + num(y) + "," + num(q);
  });
  Outcome o;
  const nlohmann::json j = check("k.toml", "k_reordered.csv", &o);
  ASSERT_TRUE(j.is_object()) << o.output;
  EXPECT_NEAR(j["action"].get<double>(), kLineAction, 1e-12) << o.output;
}

TEST_F(Columns, SolvedTrajectoryOfCoordinateKReadsBack) {
  const Outcome solved = pardel({"solve", (dir_ / "k.toml").string(), "--out", (dir_ / "k_out").string(), "--no-plot",
                                 "--quiet"},
                                "k_solve.log");
  ASSERT_EQ(solved.status, 0) << solved.output;
  EXPECT_EQ(read_text(dir_ / "k_out" / "trajectory.csv").rfind("k,t,k,y,k',y'\n", 0), 0u);
  Outcome o;
  const nlohmann::json j = check("k.toml", "k_out/trajectory.csv", &o);
  ASSERT_TRUE(j.is_object()) << o.output;
  EXPECT_NEAR(j["action"].get<double>(), kLineAction, 1e-9) << o.output;
  const nlohmann::json summary = parse_json_file(dir_ / "k_out" / "summary.json");
  ASSERT_TRUE(summary.is_object());
  EXPECT_NEAR(j["action"].get<double>(), summary["action"].get<double>(), 1e-12);
}

TEST_F(Columns, ExtraColumnsAreStillIgnored) {
  write_line("nav_extra.csv", "k,t,x,y,note", [](int k, double t, double q, double y) {
    return std::to_string(k) + "," + num(30 * t) + "," + num(2 * q) + "," + num(2.5 * y) + ",7";
  });
  Outcome o;
  const nlohmann::json j = check("nav.toml", "nav_extra.csv", &o);
  EXPECT_TRUE(j.is_object()) << o.output;
  EXPECT_EQ(j.value("N", -1), 4) << o.output;
}

/** A fuel_nav trajectory file with `header` and 5 rows of as many cells. */
void write_cells(const fs::path& path, const std::string& header) {
  const std::size_t cells = static_cast<std::size_t>(std::count(header.begin(), header.end(), ',')) + 1;
  std::string text = header + "\n";
  for (int k = 0; k <= 4; ++k) {
    text += std::to_string(k);
    for (std::size_t c = 1; c < cells; ++c) text += "," + std::to_string(k);
    text += "\n";
  }
  write_text(path, text);
}

TEST_F(Columns, DuplicateCoordinateColumn) {
  write_cells(dir_ / "dup_x.csv", "k,t,x,x,y");
  expect_refused("nav.toml", "dup_x.csv", "1:7: error: duplicate column 'x'");
}

TEST_F(Columns, DuplicateIndexColumn) {
  write_cells(dir_ / "dup_k.csv", "k,k,t,x,y");
  expect_refused("nav.toml", "dup_k.csv", "1:3: error: duplicate column 'k'");
}

TEST_F(Columns, DuplicateTimeColumn) {
  write_cells(dir_ / "dup_t.csv", "k,t,t,x,y");
  expect_refused("nav.toml", "dup_t.csv", "1:5: error: duplicate column 't'");
}

TEST_F(Columns, DuplicateExtraColumn) {
  write_cells(dir_ / "dup_note.csv", "k,t,x,y,note,note");
  expect_refused("nav.toml", "dup_note.csv", "1:14: error: duplicate column 'note'");
}

TEST_F(Columns, ThirdColumnNamedKForCoordinateK) {
  write_cells(dir_ / "dup_kk.csv", "k,t,k,k,y");
  expect_refused("k.toml", "dup_kk.csv", "1:7: error: duplicate column 'k'");
}

TEST_F(Columns, DuplicateColumnInACsvGuess) {
  write_cells(dir_ / "dup_guess.csv", "k,t,x,y,y");
  write_text(dir_ / "dup_guess.toml", kScene + "[guess]\nkind = \"csv\"\npath = \"dup_guess.csv\"\n");
  const Outcome o = pardel({"solve", (dir_ / "dup_guess.toml").string(), "--out", (dir_ / "dup_out").string(),
                            "--no-plot", "--quiet"},
                           "dup_guess.log");
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find((dir_ / "dup_guess.csv").string() + ":1:9: error: duplicate column 'y'"), std::string::npos)
      << o.output;
  EXPECT_FALSE(fs::exists(dir_ / "dup_out"));
}

TEST_F(Columns, LineOverAMebibyteIsRefused) {
  write_text(dir_ / "long_line.csv", "k,t,x,y\n0,0,0," + std::string((1 << 20) + 10, '0') + "\n");
  expect_refused("nav.toml", "long_line.csv", "2:1: error: line 2 is longer than 1 MiB");
}

TEST_F(Columns, SparseFileUnderTheLimitIsRefusedByItsFirstLine) {
  // 100 MB of zero bytes (a hole, under the 512 MiB limit): refused after reading its first MiB.
  write_text(dir_ / "sparse.csv", "");
  fs::resize_file(dir_ / "sparse.csv", 100000000);
  const std::vector<std::string> args = {"check", (dir_ / "nav.toml").string(), "--trajectory",
                                         (dir_ / "sparse.csv").string()};
  const Measured m = run_measured(PARDEL_CLI_PATH, args, dir_ / "sparse.log", {});
  EXPECT_FALSE(m.outcome.timed_out);
  EXPECT_EQ(m.outcome.status, 2) << m.outcome.output;
  EXPECT_NE(m.outcome.output.find("sparse.csv:1:1: error: line 1 is longer than 1 MiB"), std::string::npos)
      << m.outcome.output;
  EXPECT_LT(m.max_rss_kib, 256 * 1024);
}

// ---------------------------------------------------------------------------------------------
// Paths that are not UTF-8

class NonUtf8Paths : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { dir_ = scratch_folder("pardel_non_utf8"); }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static Outcome pardel(const std::vector<std::string>& args, const std::string& log) {
    return run_pardel(args, dir_ / log, {"PARDEL_CACHE_DIR=" + (dir_ / "cache").string()}, 120);
  }
  static fs::path dir_;
};

fs::path NonUtf8Paths::dir_;

const std::string kLatin1 = "sc\xe8ne";  // "scène" in ISO 8859-1: not UTF-8

TEST_F(NonUtf8Paths, SolveKeepsItsSummary) {
  const fs::path scene = dir_ / (kLatin1 + ".toml");
  const fs::path out = dir_ / ("out_" + kLatin1 + "\xff");
  write_text(scene, kScene);
  const Outcome o = pardel({"solve", scene.string(), "--out", out.string(), "--no-plot", "--quiet"}, "solve.log");
  EXPECT_EQ(o.status, 0) << o.output;
  const nlohmann::json summary = parse_json_file(out / "summary.json");
  ASSERT_TRUE(summary.is_object()) << "summary.json is missing or not valid JSON";
  EXPECT_EQ(summary["status"], "converged");
  // The invalid byte is written as U+FFFD; the rest of the path as it is.
  EXPECT_EQ(summary["scene"].get<std::string>(), (dir_ / "sc\xef\xbf\xbdne.toml").string());
  EXPECT_TRUE(fs::exists(out / "trajectory.csv"));
}

TEST_F(NonUtf8Paths, InterruptedSolveResumes) {
  // The checkpoint keeps the scene's path byte by byte (scene.path_bytes), so --resume finds it.
  const fs::path scene = dir_ / (kLatin1 + "_long.toml");
  write_text(scene, kScene + "[solver]\nmethod = \"jacobi\"\nmax_iterations = 100000000\n");
  const fs::path out = dir_ / ("resume_" + kLatin1);
  const pid_t pid = start_pardel({"solve", scene.string(), "--out", out.string(), "--no-plot", "--quiet", "--set",
                                  "grid.N=2000"},
                                 dir_ / "interrupted.log");
  std::this_thread::sleep_for(std::chrono::seconds(2));
  ::kill(pid, SIGTERM);
  const Outcome stopped = finish_pardel(pid, dir_ / "interrupted.log");
  ASSERT_EQ(stopped.status, 6) << stopped.output;
  const nlohmann::json checkpoint = parse_json_file(out / "checkpoint.json");
  ASSERT_TRUE(checkpoint.is_object()) << "checkpoint.json is missing or not valid JSON";
  const auto bytes = checkpoint["body"]["scene"]["path_bytes"].get<std::vector<unsigned char>>();
  EXPECT_EQ(std::string(bytes.begin(), bytes.end()), scene.string());
  // A warm start with Newton, which converges at once.
  const Outcome resumed = pardel(
      {"solve", "--resume", out.string(), "--set", "solver.method=newton", "--no-plot", "--quiet"}, "resumed.log");
  EXPECT_EQ(resumed.status, 0) << resumed.output;
  const nlohmann::json summary = parse_json_file(out / "summary.json");
  ASSERT_TRUE(summary.is_object());
  EXPECT_EQ(summary["status"], "converged");
}

TEST_F(NonUtf8Paths, CheckJsonNamesTheTrajectory) {
  write_text(dir_ / "nav.toml", kScene);
  const fs::path out = dir_ / "nav_out";
  ASSERT_EQ(pardel({"solve", (dir_ / "nav.toml").string(), "--out", out.string(), "--no-plot", "--quiet"},
                   "nav.log")
                .status,
            0);
  const fs::path csv = dir_ / (kLatin1 + ".csv");
  fs::copy_file(out / "trajectory.csv", csv);
  const Outcome o =
      pardel({"check", (dir_ / "nav.toml").string(), "--trajectory", csv.string(), "--json"}, "check.log");
  EXPECT_EQ(o.status, 0) << o.output;
  nlohmann::json j;
  EXPECT_NO_THROW(j = nlohmann::json::parse(o.output.substr(o.output.find('{')))) << o.output;
  EXPECT_EQ(j.value("N", -1), 20);
}

TEST_F(NonUtf8Paths, SweepWritesValidJson) {
  write_text(dir_ / "base.toml", kScene);
  const fs::path sweep = dir_ / (kLatin1 + "_sweep.toml");
  write_text(sweep, "scene = \"base.toml\"\n");
  const fs::path out = dir_ / ("sweep_out_" + kLatin1);
  const Outcome o = pardel({"sweep", sweep.string(), "--out", out.string(), "--no-plot", "--quiet"}, "sweep.log");
  EXPECT_EQ(o.status, 0) << o.output;
  const nlohmann::json j = parse_json_file(out / "sweep.json");
  EXPECT_TRUE(j.is_object()) << "sweep.json is missing or not valid JSON";
}

TEST_F(NonUtf8Paths, LagFileNameCompiles) {
  const fs::path lag = dir_ / ("mod\xe8le.lag");
  write_text(lag, "model latin1_name\ncoords x\nL = x'^2/2 - x^2/2\n");
  const Outcome o = pardel({"kernels", "--model", lag.string(), "--disc", "trapezoid", "--h", "0.5", "--t0", "0",
                            "--t1", "0.5", "--q0", "1", "--q1", "1.25"},
                           "kernels.log");
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find("\"Ld\": -0.2578125,"), std::string::npos) << o.output;
}

TEST_F(NonUtf8Paths, SceneInSuchAFolderNamingALagFileSolves) {
  // TOML text is UTF-8, so the scene names the .lag file relative to its own folder, whose name is not.
  const fs::path folder = dir_ / ("mod\xe8les");
  fs::create_directories(folder);
  write_text(folder / "free.lag", "model free_particle\ncoords x\nL = x'^2/2\n");
  const fs::path scene = folder / (kLatin1 + ".toml");
  write_text(scene, "model = \"free.lag\"\n[grid]\nT = 1\nN = 8\n[boundary]\nq0 = [0]\nqN = [2]\n");
  const fs::path out = folder / "out";
  const Outcome o = pardel({"solve", scene.string(), "--out", out.string(), "--no-plot", "--quiet"}, "lag_scene.log");
  EXPECT_EQ(o.status, 0) << o.output;
  const nlohmann::json summary = parse_json_file(out / "summary.json");
  ASSERT_TRUE(summary.is_object()) << "summary.json is missing or not valid JSON";
  EXPECT_NEAR(summary["action"].get<double>(), 2.0, 1e-12);  // T v^2 / 2 with v = 2
  EXPECT_EQ(summary["model_source"].get<std::string>(), (dir_ / "mod\xef\xbf\xbdles" / "free.lag").string());
}

}  // namespace
