// The cache of models compiled on first use (PARDEL_CACHE_DIR, else XDG_CACHE_HOME/pardel, else
// ~/.cache/pardel), driven through the built `pardel kernels --model FILE.lag`: three processes
// compiling one model at once, a failure of the C++ compiler (a header shadowed through
// CPLUS_INCLUDE_PATH) and of the generator, a process killed as it moves a compiled model into
// the cache, damaged entries (truncated or missing shared object, missing model name), a cache
// folder that is a file, the relocation variables, and an edited file. Each must end with the
// right kernels or a message (exit status 2), a cache holding only complete entries, no crash, no
// hang. The generator's warnings about a model it accepts reach stderr, from a fresh build and from
// the cache, once per run.
#include <gtest/gtest.h>

#include <csignal>
#include <string>
#include <vector>

#include "pardel_process.hpp"

namespace {

using namespace reliability;

const std::string kModel = "model cached_twin\ncoords x\nparam k = 3\nL = x'^2/2 - k*x^2/2\n";

class ModelCache : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = scratch_folder("pardel_model_cache");
    cache_ = dir_ / "cache";
    lag_ = dir_ / "cached.lag";
    write_text(lag_, kModel);
  }
  void TearDown() override { fs::remove_all(dir_); }

  Outcome kernels(const std::vector<std::string>& env, const std::string& log = "kernels.log") {
    return run_pardel(kernel_args(), dir_ / log, env);
  }
  std::vector<std::string> kernel_args() const {
    return {"kernels", "--model", lag_.string(), "--disc", "trapezoid", "--h", "0.5", "--t0", "0", "--t1", "0.5",
            "--q0", "1", "--q1", "1.25"};
  }
  std::vector<std::string> in_cache() const { return {"PARDEL_CACHE_DIR=" + cache_.string()}; }

  /** Names in a cache folder: complete entries and anything else. */
  static std::vector<std::string> entries(const fs::path& cache) {
    std::vector<std::string> names;
    std::error_code ec;
    for (fs::directory_iterator it(cache, ec); !ec && it != fs::directory_iterator(); it.increment(ec))
      names.push_back(it->path().filename().string());
    return names;
  }
  /** Exactly one entry, complete (a shared object and the model's name), and nothing else. */
  static fs::path expect_one_complete_entry(const fs::path& cache) {
    const auto names = entries(cache);
    EXPECT_EQ(names.size(), 1u);
    if (names.size() != 1) return {};
    const fs::path entry = cache / names[0];
    EXPECT_EQ(names[0].find(".tmp."), std::string::npos) << names[0];
    EXPECT_GT(fs::file_size(entry / "model.so"), 0u);
    EXPECT_EQ(read_text(entry / "model_name.txt"), "cached_twin");
    return entry;
  }

  fs::path dir_, cache_, lag_;
};

/** The trapezoid value of L = x'^2/2 - 3 x^2/2 from x = 1 to 1.25 on h = 0.5, as pardel prints it. */
const char* kExpectedLd = "\"Ld\": -0.8984375,";

TEST_F(ModelCache, FirstUseCompilesIntoTheCache) {
  const Outcome o = kernels(in_cache());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find(kExpectedLd), std::string::npos) << o.output;
  expect_one_complete_entry(cache_);
}

TEST_F(ModelCache, ThreeConcurrentCompilesOfOneModel) {
  std::vector<pid_t> pids;
  for (int i = 0; i < 3; ++i) pids.push_back(start_pardel(kernel_args(), dir_ / ("c" + std::to_string(i)), in_cache()));
  std::vector<std::string> outputs;
  for (int i = 0; i < 3; ++i) {
    const Outcome o = finish_pardel(pids[i], dir_ / ("c" + std::to_string(i)));
    EXPECT_EQ(o.status, 0) << o.output;
    outputs.push_back(o.output);
  }
  EXPECT_NE(outputs[0].find(kExpectedLd), std::string::npos) << outputs[0];
  EXPECT_EQ(outputs[1], outputs[0]);
  EXPECT_EQ(outputs[2], outputs[0]);
  expect_one_complete_entry(cache_);
}

TEST_F(ModelCache, CompilerFailureLeavesNothingAndSaysWhichStepFailed) {
  fs::create_directories(dir_ / "shadow");
  write_text(dir_ / "shadow" / "cmath", "#error injected compiler failure\n");
  const Outcome o = kernels({"PARDEL_CACHE_DIR=" + cache_.string(), "CPLUS_INCLUDE_PATH=" + (dir_ / "shadow").string()});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("cannot load '" + lag_.string() + "': compiling the kernels of " + lag_.string() + " failed"),
            std::string::npos)
      << o.output;
  EXPECT_NE(o.output.find("#error injected compiler failure"), std::string::npos) << o.output;
  EXPECT_TRUE(entries(cache_).empty()) << entries(cache_).front();
  // With the compiler working again, the model compiles.
  const Outcome again = kernels(in_cache(), "again.log");
  EXPECT_EQ(again.status, 0) << again.output;
  expect_one_complete_entry(cache_);
}

TEST_F(ModelCache, GeneratorFailureLeavesNothing) {
  write_text(lag_, "model cached_twin\ncoords x\nL = x'^2/2 - k*x^2/2\n");
  const Outcome o = kernels(in_cache());
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find(lag_.filename().string() + ":3:"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("unknown identifier 'k'"), std::string::npos) << o.output;
  EXPECT_TRUE(entries(cache_).empty());
}

TEST_F(ModelCache, KilledWhileMovingTheModelIntoTheCache) {
  // The entry's name, learnt from a compile into another cache (it does not depend on the folder).
  ASSERT_EQ(kernels({"PARDEL_CACHE_DIR=" + (dir_ / "probe").string()}, "probe.log").status, 0);
  const auto probe = entries(dir_ / "probe");
  ASSERT_EQ(probe.size(), 1u);
  const Outcome killed = kernels({"PARDEL_CACHE_DIR=" + cache_.string(),
                                  std::string("LD_PRELOAD=") + PARDEL_FAULT_INJECT_PATH,
                                  "PARDEL_FAULT_RENAME=" + probe[0], "PARDEL_FAULT_SIGNAL=9"},
                                 "killed.log");
  EXPECT_EQ(killed.status, 128 + SIGKILL) << killed.output;
  EXPECT_FALSE(fs::exists(cache_ / probe[0])) << "a killed compile left an entry";
  const Outcome again = kernels(in_cache(), "again.log");
  EXPECT_EQ(again.status, 0) << again.output;
  EXPECT_NE(again.output.find(kExpectedLd), std::string::npos) << again.output;
  // The killed compile's temporary folder is gone with the next compile of the model.
  expect_one_complete_entry(cache_);
}

TEST_F(ModelCache, TruncatedSharedObjectIsCompiledAgain) {
  ASSERT_EQ(kernels(in_cache()).status, 0);
  const fs::path entry = expect_one_complete_entry(cache_);
  write_text(entry / "model.so", "\x7f" "ELF");
  const Outcome o = kernels(in_cache(), "again.log");
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find(kExpectedLd), std::string::npos) << o.output;
  expect_one_complete_entry(cache_);
}

TEST_F(ModelCache, EntryWithoutItsSharedObjectIsCompiledAgain) {
  ASSERT_EQ(kernels(in_cache()).status, 0);
  const fs::path entry = expect_one_complete_entry(cache_);
  fs::remove(entry / "model.so");
  const Outcome o = kernels(in_cache(), "again.log");
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find(kExpectedLd), std::string::npos) << o.output;
  expect_one_complete_entry(cache_);
}

TEST_F(ModelCache, EntryWithoutItsModelNameIsCompiledAgain) {
  ASSERT_EQ(kernels(in_cache()).status, 0);
  const fs::path entry = expect_one_complete_entry(cache_);
  fs::remove(entry / "model_name.txt");
  const Outcome o = kernels(in_cache(), "again.log");
  EXPECT_EQ(o.status, 0) << o.output;
  expect_one_complete_entry(cache_);
}

TEST_F(ModelCache, CacheFolderIsAFile) {
  write_text(dir_ / "not_a_folder", "x");
  const Outcome o = kernels({"PARDEL_CACHE_DIR=" + (dir_ / "not_a_folder").string()});
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("cannot load '" + lag_.string() + "'"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find((dir_ / "not_a_folder").string()), std::string::npos) << o.output;
  EXPECT_EQ(read_text(dir_ / "not_a_folder"), "x");
}

TEST_F(ModelCache, XdgCacheHomeWhenNoPardelCacheDir) {
  const Outcome o = kernels({"-PARDEL_CACHE_DIR", "XDG_CACHE_HOME=" + (dir_ / "xdg").string()});
  EXPECT_EQ(o.status, 0) << o.output;
  expect_one_complete_entry(dir_ / "xdg" / "pardel");
}

TEST_F(ModelCache, HomeCacheWhenNeitherVariable) {
  const Outcome o = kernels({"-PARDEL_CACHE_DIR", "-XDG_CACHE_HOME", "HOME=" + (dir_ / "home").string()});
  EXPECT_EQ(o.status, 0) << o.output;
  expect_one_complete_entry(dir_ / "home" / ".cache" / "pardel");
}

TEST_F(ModelCache, EditedFileIsCompiledAgain) {
  ASSERT_EQ(kernels(in_cache()).status, 0);
  write_text(lag_, "model cached_twin\ncoords x\nparam k = 5\nL = x'^2/2 - k*x^2/2\n");
  const Outcome o = kernels(in_cache(), "edited.log");
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(o.output.find(kExpectedLd), std::string::npos) << "the old kernels were used: " << o.output;
  EXPECT_EQ(entries(cache_).size(), 2u);
}

// A model whose W = d2L/dq'dq' = diag(s, 1) is singular on the line s = 0 only: the generator
// accepts it with a warning, which must reach the user although the build succeeds.
const std::string kFoldModel =
    "# W = diag(s, 1): singular on the line s = 0 only\n"
    "model fold_plane\n"
    "coords r s\n"
    "L = 1/2*(s*r'^2 + s'^2) - 1/2*(r^2 + s^2)\n"
    "discretizations midpoint\n";
const char* kFoldWarning =
    "fold.lag:4:5: warning: model 'fold_plane': W = d2L/dq'dq' (the Hessian of L in r', s') is singular on "
    "part of the domain: det W = s changes sign between sample points and vanishes near s = 0";

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::vector<std::string> fold_kernel_args(const fs::path& lag) {
  return {"kernels", "--model", lag.string(), "--disc", "midpoint", "--h", "0.5", "--t0", "0", "--t1", "0.5",
          "--q0", "0,1", "--q1", "0.5,1.25"};
}

TEST_F(ModelCache, GeneratorWarningsAreReportedOnBuildAndOnReuse) {
  const fs::path fold = dir_ / "fold.lag";
  write_text(fold, kFoldModel);
  const Outcome built = run_pardel(fold_kernel_args(fold), dir_ / "built.log", in_cache());
  ASSERT_EQ(built.status, 0) << built.output;
  EXPECT_EQ(count(built.output, kFoldWarning), 1u) << built.output;
  EXPECT_NE(built.output.find(fold.string() + ":4:5: warning: "), std::string::npos) << "the file: " << built.output;
  EXPECT_NE(built.output.find("\n  L = 1/2*(s*r'^2 + s'^2) - 1/2*(r^2 + s^2)\n      ^\n"), std::string::npos)
      << "the source line and caret: " << built.output;
  EXPECT_NE(built.output.find("\"Ld\": "), std::string::npos) << built.output;
  const auto names = entries(cache_);
  ASSERT_EQ(names.size(), 1u);
  EXPECT_NE(read_text(cache_ / names[0] / "warnings.txt").find(kFoldWarning), std::string::npos);

  // From the cache: the same warning, once.
  const Outcome reused = run_pardel(fold_kernel_args(fold), dir_ / "reused.log", in_cache());
  ASSERT_EQ(reused.status, 0) << reused.output;
  EXPECT_EQ(count(reused.output, kFoldWarning), 1u) << reused.output;

  // An entry written before warnings.txt was kept: the warning is read from the generator's log.
  fs::remove(cache_ / names[0] / "warnings.txt");
  const Outcome old_entry = run_pardel(fold_kernel_args(fold), dir_ / "old_entry.log", in_cache());
  ASSERT_EQ(old_entry.status, 0) << old_entry.output;
  EXPECT_EQ(count(old_entry.output, kFoldWarning), 1u) << old_entry.output;
  EXPECT_EQ(entries(cache_).size(), 1u);
}

TEST_F(ModelCache, SolveReportsTheGeneratorsWarningOnce) {
  const fs::path fold = dir_ / "fold.lag";
  write_text(fold, kFoldModel);
  const fs::path scene = dir_ / "fold.toml";
  write_text(scene,
             "model = \"fold.lag\"\ndiscretization = \"midpoint\"\n[grid]\nT = 1.0\nN = 20\n"
             "[boundary]\nq0 = [0, 1]\nqN = [0.5, 1.5]\n");
  const Outcome o = run_pardel({"solve", scene.string(), "--out", (dir_ / "out").string(), "--threads", "1",
                                "--no-plot", "--quiet"},
                               dir_ / "solve.log", in_cache());
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(count(o.output, kFoldWarning), 1u) << o.output;
}

TEST_F(ModelCache, ARegularModelPrintsNoWarning) {
  const Outcome o = kernels(in_cache());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_EQ(o.output.find("warning"), std::string::npos) << o.output;
  expect_one_complete_entry(cache_);
}

}  // namespace
