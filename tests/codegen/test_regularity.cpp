// Tests of the regularity check (codegen/src/regularity.cpp) on the models of regularity/: refusals
// name the model, the file, the line and column of `L = ...` (or of the discretization) and the
// coordinates involved; warnings only where det W is shown to vanish; the opt-outs; determinism.
#include <gtest/gtest.h>

#include <dirent.h>

#include <string>
#include <vector>

#include "pardel_codegen/lag_parser.hpp"
#include "pardel_codegen/regularity.hpp"

namespace {

using pardel_codegen::LagError;
using pardel_codegen::LagModel;

std::string path_of(const std::string& name) {
  return std::string(PARDEL_CODEGEN_TEST_DIR) + "/regularity/" + name + ".lag";
}

LagModel load(const std::string& name) { return pardel_codegen::parse_lag_file(path_of(name)); }

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/** The LagError with which check_regularity refuses `model` (a failure, and an empty error, where
 *  the model is accepted). */
LagError refusal(const LagModel& model) {
  try {
    pardel_codegen::check_regularity(model, false);
  } catch (const LagError& e) {
    return e;
  }
  ADD_FAILURE() << "model '" << model.name << "' was accepted";
  return LagError("", 0, 0, "");
}

/** A model that must be refused: where, and fragments the message must hold. */
struct Refusal {
  std::string name;
  int line, col;
  std::vector<std::string> fragments;
};

class RegularityRefusal : public ::testing::TestWithParam<Refusal> {};

TEST_P(RegularityRefusal, NamesModelFileLineAndCoordinates) {
  const Refusal& r = GetParam();
  const LagModel model = load(r.name);
  {
    const LagError e = refusal(model);
    const std::string what = e.what();
    EXPECT_EQ(e.line(), r.line) << what;
    EXPECT_EQ(e.column(), r.col) << what;
    const std::string head = path_of(r.name) + ":" + std::to_string(r.line) + ":" + std::to_string(r.col) + ": error: ";
    EXPECT_EQ(what.rfind(head, 0), 0u) << what;
    EXPECT_TRUE(contains(e.message(), "model '" + r.name + "'")) << what;
    for (const std::string& f : r.fragments) EXPECT_TRUE(contains(e.message(), f)) << "missing: " << f << "\n" << what;
    // The source line with a caret under the column, then what it means and how to opt out.
    EXPECT_TRUE(contains(what, "\n  " + model.source_lines[static_cast<std::size_t>(r.line - 1)] + "\n")) << what;
    EXPECT_TRUE(contains(what, "\n  " + std::string(static_cast<std::size_t>(r.col - 1), ' ') + "^\n")) << what;
    EXPECT_TRUE(contains(what, "# pardel: allow-singular")) << what;
  }
  // The opt-out turns the refusal into a warning with the same content.
  const std::vector<std::string> warnings = pardel_codegen::check_regularity(model, true);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_TRUE(contains(warnings[0], ": warning: model '" + r.name + "'")) << warnings[0];
  EXPECT_TRUE(contains(warnings[0], "(allowed: allow-singular)")) << warnings[0];
}

const std::string kMeaning = "the DEL equations are not regular";

INSTANTIATE_TEST_SUITE_P(
    Models, RegularityRefusal,
    ::testing::Values(
        Refusal{"sum_coupled", 6, 5, {"rank 1 of 2", "W annihilates the direction (1, -1) in (p', r'): L has no kinetic term along it"}},
        Refusal{"jerk_missing", 5, 5, {"d2L/dq'''dq'''", "rank 1 of 2", "L does not depend on a'''"}},
        Refusal{"linear_top", 5, 5, {"rank 0 of 1", "L is at most linear in u''"}},
        Refusal{"radial_free", 5, 5, {"rank 1 of 2", "W annihilates q at every sample point"}},
        Refusal{"alpha_zero", 6, 24,
                {"discretization 'trapezoid(alpha=0)' is not regular", "D12 Ld is singular"}}),
    [](const ::testing::TestParamInfo<Refusal>& info) { return info.param.name; });

TEST(Regularity, RefusalSaysWhatItMeans) {
  const std::string what = refusal(load("jerk_missing")).what();
  EXPECT_TRUE(contains(what, kMeaning)) << what;
  EXPECT_TRUE(contains(what, "Newton's and Jacobi's iterations need W invertible")) << what;
}

TEST(Regularity, ALagrangianThatCannotBeDifferentiatedIsRefusedAtItsLine) {
  const LagError e = refusal(load("zero_base_power"));
  const std::string what = e.what();
  EXPECT_EQ(what.rfind(path_of("zero_base_power") + ":4:5: error: model 'u': L cannot be differentiated", 0), 0u)
      << what;
  EXPECT_TRUE(contains(what, "division by zero")) << what;
  EXPECT_EQ(e.line(), 4);
  EXPECT_EQ(e.column(), 5);
}

TEST(Regularity, WarnsWhereDetWChangesSignThroughAZero) {
  const std::vector<std::string> warnings = pardel_codegen::check_regularity(load("cubic_fold"), false);
  ASSERT_EQ(warnings.size(), 1u);
  const std::string& w = warnings[0];
  EXPECT_EQ(w.rfind(path_of("cubic_fold") + ":5:5: warning: model 'cubic_fold'", 0), 0u) << w;
  EXPECT_TRUE(contains(w, "s^3")) << w;                   // det W as GiNaC prints it
  EXPECT_TRUE(contains(w, "vanishes near s = 1;")) << w;  // the zero, on the variable det W depends on
  const pardel_codegen::RegularityFindings f = pardel_codegen::analyze_regularity(load("cubic_fold"));
  EXPECT_EQ(f.rank, 2);
  EXPECT_TRUE(f.zero_found);
  EXPECT_EQ(f.zero_point, "s = 1");
}

// No false alarms: a det W bounded away from zero, one that depends on the params only, one
// that changes sign through a pole, and one whose coordinates are in units 1e40 apart.
TEST(Regularity, SilentWithoutAZero) {
  for (const char* name : {"never_singular", "param_det", "pole_det", "far_units"}) {
    const LagModel model = load(name);
    EXPECT_TRUE(pardel_codegen::check_regularity(model, false).empty()) << name;
    const pardel_codegen::RegularityFindings f = pardel_codegen::analyze_regularity(model);
    EXPECT_EQ(f.rank, 2) << name;
    EXPECT_FALSE(f.zero_found) << name << ": " << f.zero_point;
  }
}

TEST(Regularity, APoleIsNotTakenForAZero) {
  // det W = 1/u takes both signs at the sample points; the bisections end at the pole u = 0.
  const pardel_codegen::RegularityFindings f = pardel_codegen::analyze_regularity(load("pole_det"));
  EXPECT_GE(f.points, 20);
  EXPECT_GT(f.pairs_bisected, 0);
  EXPECT_FALSE(f.zero_found);
}

TEST(Regularity, UnevaluableModelIsReportedNotRefused) {
  const std::vector<std::string> warnings = pardel_codegen::check_regularity(load("complex_everywhere"), false);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_TRUE(contains(warnings[0], "complex_everywhere.lag:4:5: warning: model 'complex_everywhere': regularity not checked"))
      << warnings[0];
}

TEST(Regularity, PragmaLineAllowsASingularModel) {
  const LagModel model = load("allowed_degenerate");
  EXPECT_TRUE(pardel_codegen::declares_allow_singular(model));
  const std::vector<std::string> warnings = pardel_codegen::check_regularity(model, false);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_TRUE(contains(warnings[0], "allowed_degenerate.lag:5:5: warning: model 'allowed_degenerate' is not regular"))
      << warnings[0];
  EXPECT_TRUE(contains(warnings[0], "L is at most linear in z'")) << warnings[0];
  // The tag must stand on a comment line of its own; mentioned in other text it does not count.
  const LagModel other = pardel_codegen::parse_lag(
      "# a model that is not pardel: allow-singular\nmodel m\ncoords z\nL = z'*cos(z)  # pardel: allow-singular\n",
      "inline.lag");
  EXPECT_FALSE(pardel_codegen::declares_allow_singular(other));
  EXPECT_THROW(pardel_codegen::check_regularity(other, false), LagError);
}

TEST(Regularity, FindingsAreTheSameOnEveryRun) {
  for (const char* name : {"radial_free", "cubic_fold"}) {
    const LagModel model = load(name);
    const auto a = pardel_codegen::analyze_regularity(model), b = pardel_codegen::analyze_regularity(model);
    EXPECT_EQ(a.points, b.points);
    EXPECT_EQ(a.rank, b.rank);
    EXPECT_EQ(a.null_directions, b.null_directions);
    EXPECT_EQ(a.zero_point, b.zero_point);
  }
}

TEST(Regularity, LeavesGinacPrecisionAsItWas) {
  const long before = GiNaC::Digits;
  pardel_codegen::analyze_regularity(load("cubic_fold"));
  EXPECT_EQ(static_cast<long>(GiNaC::Digits), before);
}

// Every bundled model is regular and draws no warning; so are the runtime test models but
// no_velocity, which is degenerate on purpose.
TEST(Regularity, BundledModelsPass) {
  const std::string dir = std::string(PARDEL_SOURCE_DIR) + "/lagrangians";
  std::vector<std::string> files;
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d)) {
      const std::string n = e->d_name;
      if (n.size() > 4 && n.substr(n.size() - 4) == ".lag") files.push_back(dir + "/" + n);
    }
    closedir(d);
  }
  ASSERT_GE(files.size(), 10u);
  for (const std::string& file : files) {
    const LagModel model = pardel_codegen::parse_lag_file(file);
    std::vector<std::string> warnings;
    EXPECT_NO_THROW(warnings = pardel_codegen::check_regularity(model, false)) << file;
    EXPECT_TRUE(warnings.empty()) << file << ": " << (warnings.empty() ? "" : warnings[0]);
    EXPECT_EQ(pardel_codegen::analyze_regularity(model).rank, model.ncoords()) << file;
  }
  const LagModel degenerate =
      pardel_codegen::parse_lag_file(std::string(PARDEL_SOURCE_DIR) + "/tests/runtime/models/no_velocity.lag");
  const std::string what = refusal(degenerate).what();
  EXPECT_TRUE(contains(what, "no_velocity.lag:5:5: error: model 'no_velocity' is not regular")) << what;
  EXPECT_TRUE(contains(what, "L does not depend on x'; L does not depend on y'")) << what;
}

TEST(Regularity, ElasticaIsSingularAlongItsVelocityAndSaysSo) {
  const LagModel model =
      pardel_codegen::parse_lag_file(std::string(PARDEL_SOURCE_DIR) + "/tests/models/unseen/elastica.lag");
  const pardel_codegen::RegularityFindings f = pardel_codegen::analyze_regularity(model);
  EXPECT_EQ(f.rank, 1);
  ASSERT_EQ(f.null_directions.size(), 1u);
  EXPECT_TRUE(contains(f.null_directions[0], "W annihilates q' at every sample point")) << f.null_directions[0];
  EXPECT_TRUE(pardel_codegen::declares_allow_singular(model));
}

}  // namespace
