// Tests of the .lag reader: the catalogue of bad files in bad_lag/ (each names its expected
// `LINE:COL: message` in its first line) and valid edge cases (comments, blank lines, CRLF,
// exact rationals, higher derivatives, params, lets built on lets, default discretizations).
#include <gtest/gtest.h>

#include <dirent.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "pardel_codegen/lag_parser.hpp"

namespace {

using pardel_codegen::LagError;
using pardel_codegen::LagModel;
using pardel_codegen::parse_lag;

std::vector<std::string> bad_files() {
  std::vector<std::string> names;
  const std::string dir = std::string(PARDEL_CODEGEN_TEST_DIR) + "/bad_lag";
  if (DIR* d = opendir(dir.c_str())) {
    while (dirent* e = readdir(d)) {
      std::string n = e->d_name;
      if (n.size() > 4 && n.substr(n.size() - 4) == ".lag") names.push_back(n.substr(0, n.size() - 4));
    }
    closedir(d);
  }
  std::sort(names.begin(), names.end());
  return names;
}

class BadLagFile : public ::testing::TestWithParam<std::string> {};

TEST_P(BadLagFile, ReportsTheExpectedLineColumnAndMessage) {
  const std::string path = std::string(PARDEL_CODEGEN_TEST_DIR) + "/bad_lag/" + GetParam() + ".lag";
  std::ifstream in(path);
  std::string first;
  std::getline(in, first);
  const std::string tag = "# expect: ";
  ASSERT_EQ(first.rfind(tag, 0), 0u) << path << " must start with '" << tag << "LINE:COL: message'";
  std::istringstream spec(first.substr(tag.size()));
  int line = 0, col = 0;
  char colon1 = 0, colon2 = 0;
  spec >> line >> colon1 >> col >> colon2;
  std::string fragment;
  std::getline(spec, fragment);
  fragment.erase(0, fragment.find_first_not_of(' '));
  ASSERT_TRUE(line > 0 && col > 0 && colon1 == ':' && colon2 == ':' && !fragment.empty()) << first;

  try {
    pardel_codegen::parse_lag_file(path);
    FAIL() << path << " was accepted";
  } catch (const LagError& e) {
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.column(), col) << e.what();
    EXPECT_NE(e.message().find(fragment), std::string::npos) << "message: " << e.message() << "\nexpected: " << fragment;
    const std::string head = path + ":" + std::to_string(line) + ":" + std::to_string(col) + ": error: ";
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(head, 0), 0u) << what;
    // The source line (a window of it, where long) and a caret under the column follow the message.
    const std::size_t caret_line = what.rfind('\n');
    ASSERT_NE(caret_line, std::string::npos);
    EXPECT_EQ(what.back(), '^');
    std::ifstream again(path);
    std::string source;
    for (int l = 0; l < line; ++l) std::getline(again, source);
    if (source.size() <= 160) {
      EXPECT_EQ(what.size() - caret_line - 1, static_cast<std::size_t>(2 + col)) << what;
    } else {
      const std::size_t shown_line = what.rfind('\n', caret_line - 1);
      const std::string shown = what.substr(shown_line + 3, caret_line - shown_line - 3);
      const std::size_t at = what.size() - caret_line - 1 - 3;  // the caret's index in `shown`
      ASSERT_LT(at, shown.size()) << what;
      EXPECT_EQ(shown[at], source[static_cast<std::size_t>(col - 1)]) << what;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Catalogue, BadLagFile, ::testing::ValuesIn(bad_files()),
                         [](const ::testing::TestParamInfo<std::string>& info) { return info.param; });

TEST(BadLagCatalogue, HasAtLeastTwentyFiveFiles) { EXPECT_GE(bad_files().size(), 25u); }

double value_at(const GiNaC::ex& e, const GiNaC::exmap& at) {
  return GiNaC::ex_to<GiNaC::numeric>(e.subs(at).evalf()).to_double();
}

TEST(LagParser, AcceptsCommentsBlankLinesAndCrlf) {
  const std::string text =
      "# a comment\r\n\r\n   \r\nmodel  osc   # trailing comment\r\n\tcoords x\r\nparam w = 2\r\n"
      "L = 1/2*(x'^2 - w^2*x^2)\r\n# end";
  LagModel m = parse_lag(text, "crlf.lag");
  EXPECT_EQ(m.name, "osc");
  EXPECT_EQ(m.order, 1);
  ASSERT_EQ(m.coords.size(), 1u);
  ASSERT_EQ(m.params.size(), 1u);
  EXPECT_EQ(m.params[0].default_value, 2.0);
  ASSERT_EQ(m.discretizations.size(), 1u);
  EXPECT_EQ(m.discretizations[0].name, "trapezoid");
}

TEST(LagParser, KeepsRationalsExact) {
  LagModel m = parse_lag("model r\ncoords x\nL = 2/3*x + 0.1*x' + 1e-2\n", "r.lag");
  const GiNaC::ex& L = m.lagrangian;
  const GiNaC::ex expected = GiNaC::numeric(2, 3) * m.coord_symbols[0][0] +
                             GiNaC::numeric(1, 10) * m.coord_symbols[1][0] + GiNaC::numeric(1, 100);
  EXPECT_TRUE((L - expected).expand().is_zero()) << L;
}

TEST(LagParser, ReadsSecondDerivativesInOrderTwoModels) {
  LagModel m = parse_lag("model s\norder 2\ncoords x y\nL = 1/2*(x''^2 + y''^2) + x'*y\n", "s.lag");
  EXPECT_EQ(m.order, 2);
  EXPECT_EQ(m.dim(), 4);
  EXPECT_TRUE(m.lagrangian.has(m.coord_symbols[2][0]));
  EXPECT_TRUE(m.lagrangian.has(m.coord_symbols[2][1]));
  EXPECT_TRUE(m.lagrangian.has(m.coord_symbols[1][0]));
  ASSERT_EQ(m.discretizations.size(), 1u);
  EXPECT_EQ(m.discretizations[0].name, "trapezoid(alpha=1)");
  EXPECT_EQ(m.discretizations[0].ident, "trapezoid_alpha_1");
}

TEST(LagParser, LetsBuildOnEarlierLetsAndParamsMayComeLater) {
  LagModel m = parse_lag(
      "model l\ncoords x\nlet a = x + c\nlet b = a^2 + 1\nL = b*x'\nparam c = -1/4\n", "l.lag");
  ASSERT_EQ(m.params.size(), 1u);
  EXPECT_EQ(m.params[0].default_value, -0.25);
  GiNaC::exmap at;
  at[m.coord_symbols[0][0]] = 2;
  at[m.coord_symbols[1][0]] = 3;
  at[m.params[0].symbol] = 5;
  EXPECT_DOUBLE_EQ(value_at(m.lagrangian, at), ((2.0 + 5.0) * (2.0 + 5.0) + 1.0) * 3.0);
}

TEST(LagParser, OperatorPrecedenceAndAssociativity) {
  LagModel m = parse_lag("model p\ncoords x\nL = -x^2 + 2^3^2 - 8/2/2 + x'*-1\n", "p.lag");
  GiNaC::exmap at;
  at[m.coord_symbols[0][0]] = 3;
  at[m.coord_symbols[1][0]] = 5;
  EXPECT_DOUBLE_EQ(value_at(m.lagrangian, at), -9.0 + 512.0 - 2.0 - 5.0);
}

TEST(LagParser, ParamDefaultsMayBeConstantExpressions) {
  LagModel m = parse_lag("model q\ncoords x\nparam a = -2*pi\nparam b = sqrt(2)/2\nL = a*b*x'^2\n", "q.lag");
  ASSERT_EQ(m.params.size(), 2u);
  EXPECT_DOUBLE_EQ(m.params[0].default_value, -2 * 3.14159265358979323846);
  EXPECT_DOUBLE_EQ(m.params[1].default_value, std::sqrt(2.0) / 2);
}

TEST(LagParser, DiscretizationsAreCanonicalized) {
  LagModel m = parse_lag("model d\norder 2\ncoords x\nL = x''^2\ndiscretizations trapezoid(alpha = 0.5), gauss2 trapezoid(alpha=-1/3)\n",
                         "d.lag");
  ASSERT_EQ(m.discretizations.size(), 3u);
  EXPECT_EQ(m.discretizations[0].name, "trapezoid(alpha=1/2)");
  EXPECT_EQ(m.discretizations[0].ident, "trapezoid_alpha_1_2");
  EXPECT_EQ(m.discretizations[1].name, "gauss2");
  EXPECT_EQ(m.discretizations[1].consistency_order, 4);
  EXPECT_EQ(m.discretizations[2].name, "trapezoid(alpha=-1/3)");
  EXPECT_EQ(m.discretizations[2].ident, "trapezoid_alpha_m1_3");
}

TEST(LagParser, ReadsTheDeclaredCost) {
  LagModel none = parse_lag("model a\ncoords x\nL = x'^2\n", "a.lag");
  EXPECT_TRUE(none.cost_name.empty());
  LagModel fuel = parse_lag("model a\ncoords x\ncost energy_used = action\nL = x'^2\n", "a.lag");
  EXPECT_EQ(fuel.cost_name, "energy_used");
  EXPECT_EQ(fuel.cost_kind, "action");
  EXPECT_EQ(fuel.cost_line, 3);
  LagModel time = parse_lag("model a\ncoords x\nL = x'^2\nclock = 1 + x^2\ncost duration = clock\n", "a.lag");
  EXPECT_EQ(time.cost_name, "duration");
  EXPECT_EQ(time.cost_kind, "clock");
}

TEST(LagParser, TimeDependenceIsDetected) {
  EXPECT_FALSE(parse_lag("model a\ncoords x\nL = x'^2\n", "a.lag").time_dependent());
  EXPECT_TRUE(parse_lag("model a\ncoords x\nL = x'^2*cos(t)\n", "a.lag").time_dependent());
  EXPECT_TRUE(parse_lag("model a\ncoords x\nL = x'^2\nclock = 1 + t\n", "a.lag").time_dependent());
}

TEST(LagParser, OrderThreeModelWithoutDiscretizationsGetsHermiteGauss) {
  LagModel m = parse_lag("model o\norder 3\ncoords x\nL = x'''^2\nclock = 1 + x''^2\n", "o.lag");
  EXPECT_EQ(m.order, 3);
  ASSERT_EQ(m.discretizations.size(), 1u);
  EXPECT_EQ(m.discretizations[0].name, "hermite_gauss(s=3)");
  EXPECT_EQ(m.discretizations[0].ident, "hermite_gauss_s_3");
  EXPECT_EQ(m.discretizations[0].consistency_order, 6);
  EXPECT_TRUE(m.has_clock);
}

TEST(LagParser, HermiteGaussTakesItsNumberOfPoints) {
  LagModel m = parse_lag("model o\norder 4\ncoords x y\nL = x''''^2 + y''''^2\n"
                         "discretizations hermite_gauss(s = 6), hermite_gauss hermite_gauss(s=5)\n",
                         "o.lag");
  ASSERT_EQ(m.discretizations.size(), 3u);
  EXPECT_EQ(m.discretizations[0].name, "hermite_gauss(s=6)");
  EXPECT_EQ(m.discretizations[0].consistency_order, 8);
  EXPECT_EQ(m.discretizations[1].name, "hermite_gauss(s=4)");
  EXPECT_EQ(m.discretizations[1].consistency_order, 8);
  EXPECT_EQ(m.discretizations[2].stages, 5);
  EXPECT_EQ(m.discretizations[2].consistency_order, 8);
}

TEST(LagParser, ReportsAMissingFile) {
  try {
    pardel_codegen::parse_lag_file("/nonexistent/dir/none.lag");
    FAIL();
  } catch (const LagError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/none.lag:1:1: error: cannot open .lag file: No such file or "
                                         "directory"),
              std::string::npos);
  }
}

TEST(LagParser, EmptyFileReportsTheMissingModel) {
  try {
    parse_lag("", "empty.lag");
    FAIL();
  } catch (const LagError& e) {
    EXPECT_EQ(e.line(), 1);
    EXPECT_NE(e.message().find("missing 'model NAME' line"), std::string::npos);
  }
}

}  // namespace

TEST(LagDiagnostic, ALongLineIsShownAsAWindowAroundTheColumn) {
  // A line of 100 000 bytes: the diagnostic shows 160 bytes around column 50 000, cut at
  // character boundaries (two-byte characters throughout) and marked "...", with the caret under
  // the column's byte.
  std::string line;
  for (int i = 0; line.size() < 100000; ++i) line += "+v" + std::to_string(i) + "\xc3\xa9";
  const std::string d = pardel_codegen::lag_diagnostic("long.lag", line, 3, 50000, "too long");
  EXPECT_LT(d.size(), 600u) << d.size();
  const std::size_t first = d.find('\n'), second = d.find('\n', first + 1);
  ASSERT_NE(second, std::string::npos);
  const std::string shown = d.substr(first + 3, second - first - 3), caret = d.substr(second + 3);
  EXPECT_EQ(shown.substr(0, 3), "...");
  EXPECT_EQ(shown.substr(shown.size() - 3), "...");
  EXPECT_NE((shown.front() & 0xC0), 0x80);
  // The caret's byte in the window is the line's byte 49 999.
  const std::size_t caret_at = caret.size() - 1;
  ASSERT_EQ(caret.back(), '^');
  const std::size_t window_start = line.find(shown.substr(3, 40));
  ASSERT_NE(window_start, std::string::npos);
  EXPECT_EQ(window_start + (caret_at - 3), 49999u);
}

TEST(LagDiagnostic, BytesOfAFileThatIsNotTextAreShownAsQuestionMarks) {
  const std::string line = std::string("\x7f" "ELF\x02\x01\x01", 7) + std::string("\x90\xff\xfe", 3) + "x";
  const std::string d = pardel_codegen::lag_diagnostic("/bin/ls", line, 1, 1, "unexpected byte 0x7f");
  const std::string shown = d.substr(d.find('\n') + 3, d.find('\n', d.find('\n') + 1) - d.find('\n') - 3);
  EXPECT_EQ(shown, "?ELF??????x");
  // UTF-8 text is shown as it is.
  const std::string text = "L = \xce\xbb*x";
  const std::string t = pardel_codegen::lag_diagnostic("u.lag", text, 1, 5, "unknown");
  EXPECT_NE(t.find(text), std::string::npos);
}
