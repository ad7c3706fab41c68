// The cache of models compiled on first use (PARDEL_CACHE_DIR, else XDG_CACHE_HOME/pardel, else
// ~/.cache/pardel, else a private folder of the process), driven through the built `pardel kernels
// --model FILE.lag`: three processes compiling one model at once, a failure of the C++ compiler (a
// header shadowed through CPLUS_INCLUDE_PATH) and of the generator, a process killed as it moves a
// compiled model into the cache, damaged entries (truncated or missing shared object, missing model
// name), a cache folder that is a file, the relocation variables, and an edited file. Each must end
// with the right kernels or a message (exit status 2), a cache holding only complete entries, no
// crash, no hang. The generator's warnings about a model it accepts reach stderr, from a fresh build
// and from the cache, once per run.
// HostileCache.*: a cache someone else could write or plant into (no cache variables and a library
// planted in the old fixed folder, a cache folder writable by others, a link, another user's),
// entries altered after they were built (a patched, replaced, linked or others-writable model.so, a
// linked entry, an edited model name, no digests), temporary folders of compiles in progress on
// another host or in another PID namespace, and a full disk: nothing foreign is ever loaded, a bad
// entry is compiled again with a message, a refused cache is named with the reason.
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <sys/time.h>
#include <unistd.h>

#include <cctype>
#include <csignal>
#include <ctime>
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
    EXPECT_NE(read_text(entry / "sha256sums.txt").find("  model.so\n"), std::string::npos);
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
  // Private: the cache folder is this user's alone, and so is its shared object.
  struct stat st;
  ASSERT_EQ(::lstat(cache_.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0700u);
  const auto names = entries(cache_);
  ASSERT_EQ(names.size(), 1u);
  ASSERT_EQ(::lstat((cache_ / names[0] / "model.so").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 022, 0u);
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

  // An entry without its warnings.txt is compiled again (its digest is recorded): the warning once,
  // after the notice.
  fs::remove(cache_ / names[0] / "warnings.txt");
  const Outcome old_entry = run_pardel(fold_kernel_args(fold), dir_ / "old_entry.log", in_cache());
  ASSERT_EQ(old_entry.status, 0) << old_entry.output;
  EXPECT_EQ(count(old_entry.output, kFoldWarning), 1u) << old_entry.output;
  EXPECT_NE(old_entry.output.find("is compiled again: warnings.txt is missing"), std::string::npos)
      << old_entry.output;
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

// ---------------------------------------------------------------------------------------------
// HostileCache: caches and entries that someone other than the compiling process wrote.

/** The same model with k = 5: loaded in place of kModel, it prints another Ld. */
const std::string kOtherModel = "model cached_twin\ncoords x\nparam k = 5\nL = x'^2/2 - k*x^2/2\n";

class HostileCache : public ModelCache {
 protected:
  /** The name of kModel's entry, learnt from a compile into another cache. */
  std::string entry_name() {
    const Outcome o = kernels({"PARDEL_CACHE_DIR=" + (dir_ / "probe").string()}, "probe.log");
    EXPECT_EQ(o.status, 0) << o.output;
    const auto names = entries(dir_ / "probe");
    EXPECT_EQ(names.size(), 1u);
    return names.empty() ? std::string() : names[0];
  }
  /** The complete entry of kOtherModel, compiled into a cache of its own. */
  fs::path other_entry() {
    const fs::path lag = dir_ / "other.lag";
    write_text(lag, kOtherModel);
    std::vector<std::string> args = kernel_args();
    args[2] = lag.string();
    const Outcome o = run_pardel(args, dir_ / "other.log", {"PARDEL_CACHE_DIR=" + (dir_ / "other").string()});
    EXPECT_EQ(o.status, 0) << o.output;
    EXPECT_EQ(o.output.find(kExpectedLd), std::string::npos) << "kOtherModel must print another Ld";
    const auto names = entries(dir_ / "other");
    EXPECT_EQ(names.size(), 1u);
    return names.empty() ? fs::path() : dir_ / "other" / names[0];
  }
  /** kModel compiled into the cache; its entry. */
  fs::path built_entry() {
    const Outcome o = kernels(in_cache(), "first.log");
    EXPECT_EQ(o.status, 0) << o.output;
    return expect_one_complete_entry(cache_);
  }
  /** A run after the entry was altered: the right kernels from a fresh compile, and the notice. */
  void expect_compiled_again(const std::string& reason) {
    const Outcome o = kernels(in_cache(), "again.log");
    EXPECT_EQ(o.status, 0) << o.output;
    EXPECT_NE(o.output.find(kExpectedLd), std::string::npos) << "a foreign model was loaded: " << o.output;
    EXPECT_NE(o.output.find("warning: the cached model " + cache_.string() + "/"), std::string::npos) << o.output;
    EXPECT_NE(o.output.find("was not loaded and is compiled again: " + reason), std::string::npos) << o.output;
    expect_one_complete_entry(cache_);
    // The next run loads the new entry without a notice.
    const Outcome next = kernels(in_cache(), "next.log");
    EXPECT_EQ(next.status, 0) << next.output;
    EXPECT_EQ(next.output.find("compiled again"), std::string::npos) << next.output;
  }
  /** A run that must refuse the cache `cache` for `reason`, creating nothing in it. */
  void expect_refused(const std::string& cache, const std::string& reason) {
    const Outcome o = kernels({"PARDEL_CACHE_DIR=" + cache}, "refused.log");
    std::string named = cache;  // as the message names it: without a trailing '/'
    while (named.size() > 1 && named.back() == '/') named.pop_back();
    EXPECT_EQ(o.status, 2) << o.output;
    EXPECT_NE(o.output.find("cannot load '" + lag_.string() + "'"), std::string::npos) << o.output;
    EXPECT_NE(o.output.find("refusing the model cache folder " + named + " (PARDEL_CACHE_DIR): it is " + reason),
              std::string::npos)
        << o.output;
    EXPECT_EQ(o.output.find("\"Ld\""), std::string::npos) << o.output;
  }
};

TEST_F(HostileCache, NoCacheVariablesNeverLoadFromAFixedFolder) {
  // Another user plants a complete, self-consistent entry (kOtherModel's, digests and all) under
  // kModel's name in the folder an older pardel used without HOME: TMPDIR/pardel-cache-UID.
  const std::string name = entry_name();
  const fs::path planted = dir_ / "tmp" / ("pardel-cache-" + std::to_string(::getuid())) / name;
  fs::create_directories(planted.parent_path());
  fs::copy(other_entry(), planted, fs::copy_options::recursive);
  const std::string planted_so = read_text(planted / "model.so");
  const Outcome o = kernels({"-PARDEL_CACHE_DIR", "-XDG_CACHE_HOME", "-HOME", "TMPDIR=" + (dir_ / "tmp").string()});
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find(kExpectedLd), std::string::npos) << "the planted model was loaded: " << o.output;
  EXPECT_EQ(read_text(planted / "model.so"), planted_so);
  // The process's private cache is gone with it: nothing is left for another process to find.
  EXPECT_EQ(entries(dir_ / "tmp"), std::vector<std::string>{"pardel-cache-" + std::to_string(::getuid())});
}

TEST_F(HostileCache, CacheWritableByOthersIsRefused) {
  fs::create_directories(cache_);
  ::chmod(cache_.c_str(), 0770);
  expect_refused(cache_.string(), "writable by its group (mode 0770)");
  ::chmod(cache_.c_str(), 0703);
  expect_refused(cache_.string(), "writable by others (mode 0703)");
  EXPECT_TRUE(entries(cache_).empty());
  // Made private, it is used.
  ::chmod(cache_.c_str(), 0700);
  const Outcome o = kernels(in_cache(), "private.log");
  EXPECT_EQ(o.status, 0) << o.output;
  expect_one_complete_entry(cache_);
}

TEST_F(HostileCache, CacheUnderAFolderOthersCanWriteIsRefused) {
  // Whoever can write a folder above the cache can rename the cache away and put another in its
  // place: a parent of mode 0777 is refused, and nothing is made in it; with the sticky bit (as
  // /tmp has) it is not.
  const fs::path open = dir_ / "open";
  fs::create_directories(open);
  ::chmod(open.c_str(), 0777);
  const Outcome o = kernels({"PARDEL_CACHE_DIR=" + (open / "cache").string()}, "open.log");
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_NE(o.output.find("the folder " + open.string() +
                          " above it is writable by others without the sticky bit (mode 0777)"),
            std::string::npos)
      << o.output;
  EXPECT_TRUE(entries(open).empty());
  ::chmod(open.c_str(), 01777);
  const Outcome sticky = kernels({"PARDEL_CACHE_DIR=" + (open / "cache").string()}, "sticky.log");
  EXPECT_EQ(sticky.status, 0) << sticky.output;
  expect_one_complete_entry(open / "cache");
}

TEST_F(HostileCache, CacheThatIsASymbolicLinkIsRefused) {
  fs::create_directories(dir_ / "elsewhere");
  ::chmod((dir_ / "elsewhere").c_str(), 0700);
  fs::create_directory_symlink(dir_ / "elsewhere", cache_);
  expect_refused(cache_.string(), "a symbolic link");
  // A trailing slash must not make it followed.
  expect_refused(cache_.string() + "/", "a symbolic link");
  EXPECT_TRUE(entries(dir_ / "elsewhere").empty());
}

TEST_F(HostileCache, CacheOfAnotherUserIsRefused) {
  fs::path cache = cache_;
  if (::geteuid() == 0) {
    fs::create_directories(cache_);
    ::chmod(cache_.c_str(), 0700);
    ASSERT_EQ(::chown(cache_.c_str(), 65534, 65534), 0);
  } else {
    cache = "/";  // root's, not this user's
  }
  struct stat st;
  ASSERT_EQ(::lstat(cache.c_str(), &st), 0);
  expect_refused(cache.string(), "owned by user " + std::to_string(st.st_uid) + ", not by this user (" +
                            std::to_string(::geteuid()) + ")");
  if (cache == cache_) {
    EXPECT_TRUE(entries(cache_).empty());
  }
}

TEST_F(HostileCache, PatchedSharedObjectIsCompiledAgain) {
  const fs::path so = built_entry() / "model.so";
  std::string bytes = read_text(so);
  ASSERT_FALSE(bytes.empty());
  bytes.back() = static_cast<char>(bytes.back() ^ 0x01);  // the section headers: it still loads
  write_text(so, bytes);
  expect_compiled_again("model.so does not match the SHA-256 digest recorded when the entry was built");
  EXPECT_NE(read_text(so), bytes);
}

TEST_F(HostileCache, ReplacedSharedObjectIsCompiledAgain) {
  const fs::path other = other_entry();
  const fs::path entry = built_entry();
  fs::copy_file(other / "model.so", entry / "model.so", fs::copy_options::overwrite_existing);
  expect_compiled_again("model.so does not match the SHA-256 digest recorded when the entry was built");
}

TEST_F(HostileCache, SharedObjectThatIsASymbolicLinkIsCompiledAgain) {
  const fs::path other = other_entry();
  const fs::path entry = built_entry();
  fs::remove(entry / "model.so");
  fs::create_symlink(other / "model.so", entry / "model.so");
  expect_compiled_again("model.so is a symbolic link");
  EXPECT_TRUE(fs::exists(other / "model.so"));
}

TEST_F(HostileCache, SharedObjectWritableByOthersIsCompiledAgain) {
  const fs::path entry = built_entry();
  ::chmod((entry / "model.so").c_str(), 0777);
  expect_compiled_again("model.so is writable by its group and by others (mode 0777)");
}

TEST_F(HostileCache, EntryThatIsASymbolicLinkIsCompiledAgain) {
  const fs::path other = other_entry();
  const fs::path entry = built_entry();
  fs::remove_all(entry);
  fs::create_directory_symlink(other, entry);
  expect_compiled_again("the entry is a symbolic link");
  EXPECT_TRUE(fs::exists(other / "model.so")) << "the link's target was removed";
}

TEST_F(HostileCache, EditedModelNameIsCompiledAgain) {
  const fs::path entry = built_entry();
  write_text(entry / "model_name.txt", "cached_twin\n");
  expect_compiled_again("model_name.txt does not match the SHA-256 digest recorded when the entry was built");
}

TEST_F(HostileCache, EntryWithoutDigestsIsCompiledAgain) {
  const fs::path entry = built_entry();
  fs::remove(entry / "sha256sums.txt");
  expect_compiled_again("sha256sums.txt is missing");
}

/** This host's name as the loader writes it in temporary folders ('-' for anything else than a
 *  letter, a digit or '-'), and this process's PID namespace (the inode number of the link). */
std::string host_tag() {
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  std::string tag;
  for (const char* c = host; *c && tag.size() < 64; ++c)
    tag += std::isalnum(static_cast<unsigned char>(*c)) || *c == '-' ? *c : '-';
  return tag;
}
std::string pid_namespace() {
  const fs::path link = fs::read_symlink("/proc/self/ns/pid");  // "pid:[4026531836]"
  std::string digits;
  for (char c : link.string())
    if (std::isdigit(static_cast<unsigned char>(c))) digits += c;
  return digits;
}
/** A PID of no running process here (a child that has exited). */
long dead_pid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  ::waitpid(pid, nullptr, 0);
  return static_cast<long>(pid);
}

TEST_F(HostileCache, CompilesInProgressElsewhereAreNotRemoved) {
  const std::string name = entry_name();
  const std::string host = host_tag(), ns = pid_namespace(), dead = std::to_string(dead_pid());
  ASSERT_FALSE(host.empty());
  ASSERT_FALSE(ns.empty());
  fs::create_directories(cache_);
  ::chmod(cache_.c_str(), 0700);
  // Compiles whose process this host cannot see: another host (a cache on NFS), another PID
  // namespace of this host (a container), a name of an older pardel without a host. The PID is dead
  // here, and alive there.
  const std::vector<std::string> elsewhere = {name + ".tmp.other-host." + ns + "." + dead + ".Ab12Cd",
                                              name + ".tmp." + host + ".1" + ns + "." + dead + ".Ab12Cd",
                                              name + ".tmp." + dead + ".4242"};
  // Left by compiles that can no longer finish: one of this host and namespace whose process is
  // gone, and another host's untouched for two days.
  const std::vector<std::string> abandoned = {name + ".tmp." + host + "." + ns + "." + dead + ".Ef34Gh",
                                              name + ".tmp.other-host.7.7.Ij56Kl"};
  for (const auto& folder : elsewhere) fs::create_directories(cache_ / folder / "partial");
  for (const auto& folder : abandoned) fs::create_directories(cache_ / folder / "partial");
  const struct timeval two_days_ago[2] = {{::time(nullptr) - 2 * 86400, 0}, {::time(nullptr) - 2 * 86400, 0}};
  ASSERT_EQ(::utimes((cache_ / abandoned[1]).c_str(), two_days_ago), 0);

  const Outcome o = kernels(in_cache());
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find(kExpectedLd), std::string::npos) << o.output;
  for (const auto& folder : elsewhere) EXPECT_TRUE(fs::exists(cache_ / folder / "partial")) << folder << " was removed";
  for (const auto& folder : abandoned) EXPECT_FALSE(fs::exists(cache_ / folder)) << folder << " was left";
  EXPECT_TRUE(fs::exists(cache_ / name / "model.so"));
}

TEST_F(HostileCache, FullDiskLeavesNoEntry) {
  // A file-size limit (ulimit -f, in KiB, with SIGXFSZ ignored so that a write fails with EFBIG as
  // on a full disk) reached by the compile at one step or another: each run ends with the right
  // kernels and a complete entry, or with exit status 2, a message and nothing in the cache.
  int failures = 0;
  for (const int kib : {1, 4, 16, 64}) {
    std::vector<std::string> args = {"-c", "trap '' XFSZ; ulimit -f \"$0\"; exec \"$@\"", std::to_string(kib),
                                     PARDEL_CLI_PATH};
    for (const std::string& a : kernel_args()) args.push_back(a);
    const fs::path log = dir_ / ("full" + std::to_string(kib) + ".log");
    const Outcome o = finish_pardel(start_program("/bin/bash", args, log, in_cache()), log);
    if (o.status == 0) {
      EXPECT_NE(o.output.find(kExpectedLd), std::string::npos) << kib << " KiB: " << o.output;
      expect_one_complete_entry(cache_);
      fs::remove_all(cache_);
      continue;
    }
    ++failures;
    EXPECT_EQ(o.status, 2) << kib << " KiB: " << o.output;
    EXPECT_NE(o.output.find("cannot load '" + lag_.string() + "'"), std::string::npos) << kib << " KiB: " << o.output;
    EXPECT_TRUE(entries(cache_).empty()) << kib << " KiB: " << entries(cache_).front();
  }
  EXPECT_GT(failures, 0) << "no limit made the compile fail";
  const Outcome o = kernels(in_cache(), "unlimited.log");
  EXPECT_EQ(o.status, 0) << o.output;
  expect_one_complete_entry(cache_);
}

}  // namespace
