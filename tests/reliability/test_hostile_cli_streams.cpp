// Hostile cases of the command line's streams, signals and words, each run against the built
// `pardel` under a time limit: a stdout that cannot be written (a full device, a closed stdout),
// Ctrl-C and SIGTERM while `pardel check` computes, an empty --out, --resume or --trajectory, a
// misspelt subcommand, and plot.py on wind-field lets with numbers in exponent notation or with
// text it cannot read.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
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

class HostileCliStreams : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = scratch_folder("pardel_hostile_cli_streams"); }
  void TearDown() override { fs::remove_all(dir_); }

  Outcome pardel(const std::vector<std::string>& args, int limit_s = 120) {
    return run_pardel(args, dir_ / "log", {}, limit_s);
  }
  /** pardel with `args` (shell words) and its stdout redirected by `redirect` (`>/dev/full`, `>&-`),
   *  through /bin/sh; the output is its stderr alone. */
  Outcome pardel_redirected(const std::string& args, const std::string& redirect, int limit_s = 120) {
    const fs::path err = dir_ / "err";
    Outcome o = finish_pardel(start_program("/bin/sh", {"-c", "exec '" + std::string(PARDEL_CLI_PATH) + "' " + args +
                                                                  " " + redirect + " 2>'" + err.string() + "'"},
                                            dir_ / "log"),
                              dir_ / "log", limit_s);
    o.output = read_text(err);
    return o;
  }
  /** plot.py run on `out` as pardel runs it. */
  Outcome plot(const fs::path& out) {
    return finish_pardel(start_program(PARDEL_PYTHON_PATH, {PARDEL_PLOT_SCRIPT_PATH, out.string()}, dir_ / "plot.log"),
                         dir_ / "plot.log", 120);
  }
  /** The outputs of zermelo_1 (no plots), the model their summary names the zermelo model with the
   *  lets W1 and W2 (its wind) written as `w1` and `w2`. */
  fs::path zermelo_outputs_with_wind(const std::string& w1, const std::string& w2) {
    const fs::path out = dir_ / "out";
    const Outcome o = pardel({"solve", kScenes + "/zermelo_1.toml", "--out", out.string(), "--no-plot", "--quiet"});
    EXPECT_EQ(o.status, 0) << o.output;
    std::string lag = read_text(std::string(PARDEL_SOURCE_DIR) + "/lagrangians/zermelo.lag");
    for (const auto& [name, text] : {std::pair<std::string, std::string>{"W1", w1}, {"W2", w2}}) {
      const auto start = lag.find("let " + name + " = ");
      EXPECT_NE(start, std::string::npos);
      if (start != std::string::npos) lag.replace(start, lag.find('\n', start) - start, "let " + name + " = " + text);
    }
    write_text(dir_ / "wind.lag", lag);
    json summary = json::parse(read_text(out / "summary.json"));
    summary["model_source"] = (dir_ / "wind.lag").string();
    write_text(out / "summary.json", summary.dump(2));
    return out;
  }
  fs::path dir_;
};

// ---------------------------------------------------------------------------------------------
// A stdout that cannot be written

TEST_F(HostileCliStreams, StdoutThatCannotBeWrittenEndsWithStatusOneAndSaysSo) {
  // kernels, check --json and models wrote their only output to a full device or a closed stdout
  // and exited 0: `pardel kernels ... > k.json` on a full disk left an empty k.json and success.
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  const std::string kernels = "kernels --model harmonic --disc trapezoid --h 0.1 --t0 0 --t1 0.1 --q0 1 --q1 2";
  const std::string check = "check '" + kScenes + "/zermelo_1.toml'";
  const std::string solve = "solve '" + kScenes + "/zermelo_1.toml' --no-plot --out '" + (dir_ / "out").string() + "'";
  const std::pair<std::string, std::string> cases[] = {
      {kernels, ">/dev/full"},        {kernels, ">&-"},         {check + " --json", ">/dev/full"},
      {check, ">&-"},                 {"models", ">/dev/full"}, {"models --json", ">/dev/full"},
      {solve, ">/dev/full"},          {"--help", ">/dev/full"}, {"solve --help", ">&-"}};
  for (const auto& [args, redirect] : cases) {
    SCOPED_TRACE("pardel " + args + " " + redirect);
    const Outcome o = pardel_redirected(args, redirect);
    ASSERT_FALSE(o.timed_out);
    EXPECT_EQ(o.status, 1) << o.output;
    EXPECT_NE(o.output.find("pardel: error: cannot write to standard output: "), std::string::npos) << o.output;
  }
  // The reason, where the write that failed was the last one.
  EXPECT_NE(pardel_redirected(kernels, ">/dev/full").output.find("No space left on device"), std::string::npos);
  EXPECT_NE(pardel_redirected(kernels, ">&-").output.find("Bad file descriptor"), std::string::npos);
  // A stdout that works: the status of the command as before.
  EXPECT_EQ(pardel_redirected(kernels, ">/dev/null").status, 0);
}

TEST_F(HostileCliStreams, StdoutThatCannotBeWrittenKeepsTheStatusOfACommandThatFailedOtherwise) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  // Values that overflow: exit 5, as a solve that meets a value that is not finite.
  const Outcome o = pardel_redirected(
      "kernels --model harmonic --disc trapezoid --h 1e308 --t0 0 --t1 1e308 --q0 1e200 --q1 0.1", ">/dev/full");
  ASSERT_FALSE(o.timed_out);
  EXPECT_EQ(o.status, 5) << o.output;
  EXPECT_NE(o.output.find("cannot write to standard output"), std::string::npos) << o.output;
}

// ---------------------------------------------------------------------------------------------
// A signal while pardel check computes

TEST_F(HostileCliStreams, SignalDuringCheckEndsInterruptedWithAMessage) {
  // pardel check died of Ctrl-C or SIGTERM (130, 143) without a word while its certificate was
  // computed. Now it ends after the step under way, with exit 6, a message and nothing printed.
  for (const int signal : {SIGINT, SIGTERM}) {
    SCOPED_TRACE(signal == SIGINT ? "SIGINT" : "SIGTERM");
    // About 2 s of certificate work on an idle core.
    const auto start = std::chrono::steady_clock::now();
    const pid_t pid = start_pardel({"check", kScenes + "/fuel_nav.toml", "--set", "grid.N=600000"}, dir_ / "log");
    std::this_thread::sleep_for(std::chrono::milliseconds(600));
    ::kill(pid, signal);
    const Outcome o = finish_pardel(pid, dir_ / "log", 120);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_FALSE(o.timed_out) << o.output;
    EXPECT_EQ(o.status, 6) << o.output;
    EXPECT_NE(o.output.find(std::string("pardel check: stopped by ") + (signal == SIGINT ? "SIGINT (Ctrl-C)" : "SIGTERM")),
              std::string::npos)
        << o.output;
    EXPECT_NE(o.output.find("nothing printed"), std::string::npos) << o.output;
    EXPECT_EQ(o.output.find("residual:"), std::string::npos) << o.output;
    EXPECT_LT(seconds, 60) << o.output;
  }
}

TEST_F(HostileCliStreams, SecondCtrlCEndsCheckAtOnce) {
  const pid_t pid = start_pardel({"check", kScenes + "/fuel_nav.toml", "--set", "grid.N=2000000"}, dir_ / "log");
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  ::kill(pid, SIGINT);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const auto second = std::chrono::steady_clock::now();
  ::kill(pid, SIGINT);
  const Outcome o = finish_pardel(pid, dir_ / "log", 120);
  ASSERT_FALSE(o.timed_out);
  EXPECT_EQ(o.status, 128 + SIGINT) << o.output;
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - second).count(), 2.0);
}

// ---------------------------------------------------------------------------------------------
// Empty option values and misspelt subcommands

TEST_F(HostileCliStreams, EmptyPathOptionsAreRefusedNamingTheOption) {
  // `--out ''` was taken for no --out: the outputs went to the scene's output.dir, while an empty
  // output.dir is refused.
  // zermelo_1 with its output.dir in the scratch folder.
  const fs::path scene = dir_ / "scene.toml";
  std::string text = read_text(kScenes + "/zermelo_1.toml");
  const std::string dir_line = "dir = \"out/zermelo_1\"";
  ASSERT_NE(text.find(dir_line), std::string::npos);
  text.replace(text.find(dir_line), dir_line.size(), "dir = \"" + (dir_ / "scene_dir").string() + "\"");
  write_text(scene, text);
  const fs::path sweep = dir_ / "sweep.toml";
  write_text(sweep, "scene = \"" + scene.string() + "\"\n[[vary]]\nkey = \"grid.N\"\nvalues = [40, 80]\n");
  const std::pair<std::vector<std::string>, std::string> cases[] = {
      {{"solve", scene.string(), "--out", "", "--no-plot", "--quiet"}, "--out"},
      {{"solve", scene.string(), "--resume", "", "--no-plot", "--quiet"}, "--resume"},
      {{"check", scene.string(), "--trajectory", ""}, "--trajectory"},
      {{"sweep", sweep.string(), "--out", "", "--no-plot", "--quiet"}, "--out"}};
  for (const auto& [args, option] : cases) {
    SCOPED_TRACE(args[0] + " " + option + " ''");
    const Outcome o = pardel(args);
    ASSERT_FALSE(o.timed_out);
    EXPECT_EQ(o.status, 2) << o.output;
    EXPECT_NE(o.output.find(option + ": must not be empty"), std::string::npos) << o.output;
    EXPECT_FALSE(fs::exists(dir_ / "scene_dir"));
  }
}

TEST_F(HostileCliStreams, MisspeltSubcommandIsNamedWithTheNearestOne) {
  // `pardel solv scene.toml` said "A subcommand is required".
  const std::pair<std::string, std::string> cases[] = {{"solv", "solve"}, {"modles", "models"}, {"chek", "check"}};
  for (const auto& [word, nearest] : cases) {
    SCOPED_TRACE(word);
    const Outcome o = pardel({word, kScenes + "/zermelo_1.toml"});
    EXPECT_EQ(o.status, 2) << o.output;
    EXPECT_NE(o.output.find("unknown subcommand '" + word + "'; did you mean '" + nearest + "'?"), std::string::npos)
        << o.output;
  }
  Outcome o = pardel({"xyzzy"});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("unknown subcommand 'xyzzy' (the subcommands: models, kernels, solve, check, sweep)"),
            std::string::npos)
      << o.output;
  o = pardel({});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("A subcommand is required"), std::string::npos) << o.output;
}

// ---------------------------------------------------------------------------------------------
// plot.py on the lets of a wind field

TEST_F(HostileCliStreams, PlotOfAWindWithNumbersInExponentNotationDrawsTheField) {
  // plot.py read the exponent of 5e-1 as a name ("5v_0-1") and ended in a SymPy traceback, with
  // neither picture drawn.
  const fs::path out = zermelo_outputs_with_wind("5e-1*s*((y - 2)/D22 + (y - 4)/D44 + (y - 5)/D25 - (y - 1)/D51)",
                                                 "1E0*s*(-(x - 2)/D22 - (x - 4)/D44 - 2.5e+0*(x - 2)/D25 + (x - 5)/D51)"
                                                 " + .5e-3");
  const Outcome o = plot(out);
  ASSERT_FALSE(o.timed_out);
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(o.output.find("Traceback"), std::string::npos) << o.output;
  EXPECT_EQ(o.output.find("not drawn"), std::string::npos) << o.output;
  EXPECT_EQ(o.output.find("skipped"), std::string::npos) << o.output;
  EXPECT_TRUE(fs::exists(out / "trajectory.png"));
  EXPECT_TRUE(fs::exists(out / "convergence.png"));
}

TEST_F(HostileCliStreams, PlotOfAWindLetItCannotReadSaysSoAndDrawsBothPictures) {
  // A let plot.py cannot translate ends the wind field, not the script: the path and the
  // convergence are drawn.
  const fs::path out = zermelo_outputs_with_wind("s*(y - 2)) / D22 (", "s*(x - 2)/D22");
  const Outcome o = plot(out);
  ASSERT_FALSE(o.timed_out);
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(o.output.find("Traceback"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("plot.py: trajectory.png: the wind field is not drawn: let W1 = s*(y - 2)) / D22 ( cannot be "
                          "read"),
            std::string::npos)
      << o.output;
  EXPECT_TRUE(fs::exists(out / "trajectory.png"));
  EXPECT_TRUE(fs::exists(out / "convergence.png"));
}

}  // namespace
