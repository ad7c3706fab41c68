// Tests of the model loader: bundled models by name, .lag files generated, compiled and loaded at
// run time (checked against the bundled build of the same file), and the errors a user sees.
#include "pardel/model_loader.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "pardel/pardel.hpp"

namespace {

namespace fs = std::filesystem;

class ModelLoaderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { setenv("PARDEL_CACHE_DIR", PARDEL_TEST_CACHE_DIR, 1); }
  static fs::path write_lag(const std::string& name, const std::string& text) {
    fs::path dir = fs::path(PARDEL_TEST_CACHE_DIR).parent_path() / "lag";
    fs::create_directories(dir);
    fs::path path = dir / name;
    std::ofstream(path) << text;
    return path;
  }
};

TEST_F(ModelLoaderTest, ResolvesBundledModelsByName) {
  ASSERT_FALSE(pardel::bundled_models().empty());
  for (const pardel_model* model : pardel::bundled_models()) {
    EXPECT_EQ(pardel::resolve_model(model->name), model);
  }
}

TEST_F(ModelLoaderTest, UnknownNameListsTheCompiledModels) {
  try {
    pardel::resolve_model("no_such_model");
    FAIL() << "expected an error";
  } catch (const pardel::ModelLoadError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("unknown model 'no_such_model'"), std::string::npos) << what;
    EXPECT_NE(what.find(pardel::bundled_models().front()->name), std::string::npos) << what;
  }
}

TEST_F(ModelLoaderTest, MissingFileIsAnError) {
  EXPECT_THROW(pardel::resolve_model("/nonexistent/dir/model.lag"), pardel::ModelLoadError);
}

// The same .lag compiled at run time evaluates to exactly what the bundled build computes.
TEST_F(ModelLoaderTest, CompiledLagMatchesTheBundledBuild) {
  if (!pardel::can_compile_lag_files()) GTEST_SKIP() << "this build has no generator";
  const pardel_model* bundled = pardel::find_model("fuel_nav");
  ASSERT_NE(bundled, nullptr);
  const pardel_model* loaded =
      pardel::resolve_model(std::string(PARDEL_SOURCE_DIR) + "/lagrangians/fuel_nav.lag");
  ASSERT_NE(loaded, nullptr);
  ASSERT_NE(loaded, bundled);
  EXPECT_STREQ(loaded->name, "fuel_nav");
  ASSERT_EQ(loaded->dim, bundled->dim);
  ASSERT_EQ(loaded->ndiscretizations, bundled->ndiscretizations);
  const int m = loaded->dim;
  const double q0[] = {0.3, -0.7}, q1[] = {0.45, -0.5};
  for (int d = 0; d < loaded->ndiscretizations; ++d) {
    std::vector<double> a(1 + 2 * m + 3 * m * m), b(a.size());
    auto eval = [&](const pardel_model* model, std::vector<double>& out) {
      double* o = out.data();
      model->discretizations[d].full(0.05, 1.0, 1.05, q0, q1, model->param_defaults, o, o + 1,
                                     o + 1 + m, o + 1 + 2 * m, o + 1 + 2 * m + m * m,
                                     o + 1 + 2 * m + 2 * m * m);
    };
    eval(loaded, a);
    eval(bundled, b);
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i], b[i]) << "output " << i;
  }
  // A second resolve is served from memory.
  EXPECT_EQ(pardel::resolve_model(std::string(PARDEL_SOURCE_DIR) + "/lagrangians/fuel_nav.lag"), loaded);
}

TEST_F(ModelLoaderTest, BadLagReportsFileLineAndColumn) {
  if (!pardel::can_compile_lag_files()) GTEST_SKIP() << "this build has no generator";
  const fs::path lag = write_lag("broken.lag",
                                 "model broken\ncoords x\nL = 1/2*x'^2 + undefined_thing\n"
                                 "discretizations trapezoid\n");
  try {
    pardel::resolve_model(lag.string());
    FAIL() << "expected an error";
  } catch (const pardel::ModelLoadError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("broken.lag:3:"), std::string::npos) << what;
    EXPECT_NE(what.find("error"), std::string::npos) << what;
  }
}

// pardel-gen's refusal of a model that is not regular reaches the user whole: file, line and
// column of L, the model, the coordinate involved and the way out.
TEST_F(ModelLoaderTest, SingularLagShowsTheGeneratorsRefusal) {
  if (!pardel::can_compile_lag_files()) GTEST_SKIP() << "this build has no generator";
  const fs::path lag = write_lag("twin_drift.lag",
                                 "model twin_drift\ncoords m n\n"
                                 "L = 1/2*(m' - 2*n')^2 + m*n\n"
                                 "discretizations trapezoid\n");
  try {
    pardel::resolve_model(lag.string());
    FAIL() << "expected an error";
  } catch (const pardel::ModelLoadError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("twin_drift.lag:3:5: error: model 'twin_drift' is not regular"), std::string::npos) << what;
    EXPECT_NE(what.find("W annihilates the direction (1, 0.5) in (m', n')"), std::string::npos) << what;
    EXPECT_NE(what.find("# pardel: allow-singular"), std::string::npos) << what;
  }
  // Declared degenerate, the same Lagrangian compiles.
  const fs::path allowed = write_lag("twin_drift_allowed.lag",
                                     "# pardel: allow-singular\nmodel twin_drift_allowed\ncoords m n\n"
                                     "L = 1/2*(m' - 2*n')^2 + m*n\n"
                                     "discretizations trapezoid\n");
  const pardel_model* model = pardel::resolve_model(allowed.string());
  ASSERT_NE(model, nullptr);
  EXPECT_STREQ(model->name, "twin_drift_allowed");
}

TEST_F(ModelLoaderTest, NewModelIsUsable) {
  if (!pardel::can_compile_lag_files()) GTEST_SKIP() << "this build has no generator";
  const fs::path lag = write_lag("spring_pair.lag",
                                 "model spring_pair\ncoords a b\nparam k = 2\n"
                                 "L = 1/2*(a'^2 + b'^2) - k/2*(a - b)^2\n"
                                 "discretizations midpoint\n");
  const pardel_model* model = pardel::resolve_model(lag.string());
  ASSERT_NE(model, nullptr);
  EXPECT_STREQ(model->name, "spring_pair");
  ASSERT_EQ(model->ndiscretizations, 1);
  // Midpoint: Ld = h*(|v|^2/2 - k/2 (am - bm)^2), v = (q1 - q0)/h, checked by hand.
  const double h = 0.1, q0[] = {1.0, 0.0}, q1[] = {1.2, 0.1}, p[] = {2.0};
  const double ld = model->discretizations[0].action(h, 0, h, q0, q1, p);
  const double va = 2.0, vb = 1.0, am = 1.1, bm = 0.05;
  EXPECT_NEAR(ld, h * (0.5 * (va * va + vb * vb) - 1.0 * (am - bm) * (am - bm)), 1e-13);
}

/** The cache folders of the entries compiled for the model `name` (model_name.txt). */
int entries_of(const std::string& name) {
  int count = 0;
  for (const auto& entry : fs::directory_iterator(PARDEL_TEST_CACHE_DIR)) {
    std::ifstream in(entry.path() / "model_name.txt");
    std::string text;
    if (in && std::getline(in, text) && text == name) ++count;
  }
  return count;
}

/** Appends a line to a file and moves its modification time a minute on (so that the change
 *  shows on every file system clock). */
void touch(const fs::path& file, const std::string& line) {
  std::ofstream(file, std::ios::app) << line;
  fs::last_write_time(file, fs::last_write_time(file) + std::chrono::minutes(1));
}

TEST_F(ModelLoaderTest, ACachedModelIsCompiledAgainWhenATemplateOrAKernelHeaderChanges) {
  if (!pardel::can_compile_lag_files()) GTEST_SKIP() << "this build has no generator";
  // A copy of the toolchain's render script, templates and kernel headers, to change.
  const pardel::LoaderToolchain original = pardel::loader_toolchain();
  const fs::path copy = fs::path(PARDEL_TEST_CACHE_DIR).parent_path() / "toolchain_copy";
  fs::remove_all(copy);
  fs::create_directories(copy / "codegen");
  const fs::path codegen = fs::path(original.render_script).parent_path();
  fs::copy_file(original.render_script, copy / "codegen" / fs::path(original.render_script).filename());
  fs::copy(codegen / "templates", copy / "codegen" / "templates", fs::copy_options::recursive);
  fs::copy(original.abi_include, copy / "include", fs::copy_options::recursive);
  pardel::LoaderToolchain changed = original;
  changed.render_script = (copy / "codegen" / fs::path(original.render_script).filename()).string();
  changed.abi_include = (copy / "include").string();
  pardel::set_loader_toolchain(changed);

  const fs::path lag = write_lag("stamp_oscillator.lag",
                                 "model stamp_oscillator\ncoords x\nparam w = 1.25\n"
                                 "L = x'^2/2 - w^2*x^2/2\ndiscretizations trapezoid\n");
  const pardel_model* first = pardel::resolve_model(lag.string());
  ASSERT_NE(first, nullptr);
  const int before = entries_of("stamp_oscillator");
  EXPECT_EQ(pardel::resolve_model(lag.string()), first);  // unchanged: the same entry
  EXPECT_EQ(entries_of("stamp_oscillator"), before);

  touch(copy / "codegen" / "templates" / "model.cpp.j2", "{# a template changed since #}\n");
  const pardel_model* second = pardel::resolve_model(lag.string());
  ASSERT_NE(second, nullptr);
  EXPECT_NE(second, first);
  EXPECT_EQ(entries_of("stamp_oscillator"), before + 1);

  touch(copy / "include" / "pardel" / "condensation.hpp", "// a kernel header changed since\n");
  const pardel_model* third = pardel::resolve_model(lag.string());
  ASSERT_NE(third, nullptr);
  EXPECT_NE(third, second);
  EXPECT_EQ(entries_of("stamp_oscillator"), before + 2);
  // Each compile is the same model: the trapezoid action, checked by hand.
  const double h = 0.2, q0[] = {0.5}, q1[] = {0.7}, p[] = {1.25};
  const double v = (0.7 - 0.5) / h;
  const double expected = h * (v * v / 2 - 1.25 * 1.25 * (0.5 * 0.5 + 0.7 * 0.7) / 4);
  for (const pardel_model* m : {first, second, third})
    EXPECT_NEAR(m->discretizations[0].action(h, 0, h, q0, q1, p), expected, 1e-14);
  pardel::set_loader_toolchain(original);
  fs::remove_all(copy);
}

}  // namespace

namespace {

// The compile notice (set_compile_notice): called once, with the path as given, when a .lag file
// without a cache entry is compiled; not for a model already loaded, not for a bundled name.
TEST_F(ModelLoaderTest, TheCompileNoticeNamesTheFileBeforeItsCompile) {
  if (!pardel::can_compile_lag_files()) GTEST_SKIP() << "this build has no generator";
  const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
  // A text of its own (the cache is keyed by the text's digest), so that it is compiled here.
  const fs::path lag = write_lag("noticed.lag", "# run " + std::to_string(stamp) +
                                                    "\nmodel noticed\ncoords x\nparam k = 3\nL = x'^2/2 - k*x^2/2\n");
  std::vector<std::string> noticed;
  pardel::set_compile_notice([&noticed](const std::string& path) { noticed.push_back(path); });
  ASSERT_NE(pardel::resolve_model("fuel_nav"), nullptr);
  EXPECT_TRUE(noticed.empty());
  const pardel_model* model = pardel::resolve_model(lag.string());
  ASSERT_NE(model, nullptr);
  ASSERT_EQ(noticed.size(), 1u);
  EXPECT_EQ(noticed[0], lag.string());
  EXPECT_EQ(pardel::resolve_model(lag.string()), model);
  EXPECT_EQ(noticed.size(), 1u);
  pardel::set_compile_notice({});
}

}  // namespace
