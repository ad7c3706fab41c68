// The cache of models compiled on first use (PARDEL_CACHE_DIR, else XDG_CACHE_HOME/pardel, else
// ~/.cache/pardel), driven through the built `pardel kernels --model FILE.lag`: three processes
// compiling one model at once, a failure of the C++ compiler (a header shadowed through
// CPLUS_INCLUDE_PATH) and of the generator, a process killed as it moves a compiled model into
// the cache, damaged entries (truncated or missing shared object, missing model name), a cache
// folder that is a file, the relocation variables, and an edited file. Each must end with the
// right kernels or a message (exit status 2), a cache holding only complete entries, no crash, no
// hang.
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

}  // namespace
