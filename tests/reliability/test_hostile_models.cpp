// Hostile .lag models through the real tool chain (pardel-gen, render.py, the C++ compiler with
// -Wall -Wextra -Werror): names that are C/C++ keywords, macros, generated temporaries or ABI
// names, very long names, non-ASCII bytes, NUL bytes, comment and string injection, deep
// nesting, huge exponents and megabyte lines. Each must be either accepted, compiled
// warning-free and evaluated correctly, or refused with FILE:LINE:COL; never a crash, a hang or
// a C++ compile error.
#include <cmath>
#include <string>
#include <vector>

#include "model_workshop.hpp"

namespace {

using reliability::expect_compiled;
using reliability::expect_located_rejection;
using reliability::expect_trapezoid_matches;
using reliability::Generated;

class HostileModel : public reliability::ModelWorkshop {};

// ---------------------------------------------------------------------------------------------
// Names

TEST_F(HostileModel, CoordinatesNamedLikeKeywordsAndMacrosCompileAndEvaluate) {
  const std::string text =
      "# coords named like C/C++ keywords, macros and standard names\n"
      "model keywords\n"
      "coords int return main __LINE__ std\n"
      "param NULL = 2\n"
      "param errno = 0.5\n"
      "let __FILE__ = int*return\n"
      "L = 1/2*(int'^2 + return'^2 + main'^2 + __LINE__'^2 + std'^2) - NULL*__FILE__ + errno*main*std\n";
  const Generated g = generate("keywords.lag", text);
  expect_compiled(g);
  if (!g.model) return;
  ASSERT_EQ(g.model->ncoords, 5);
  EXPECT_STREQ(g.model->coords[0], "int");
  EXPECT_STREQ(g.model->coords[3], "__LINE__");
  ASSERT_EQ(g.model->nparams, 2);
  EXPECT_STREQ(g.model->param_names[0], "NULL");
  EXPECT_EQ(g.model->param_defaults[0], 2.0);
  EXPECT_EQ(g.model->param_defaults[1], 0.5);
  expect_trapezoid_matches(
      *g.model,
      [](double, const double* q, const double* v, const double* p) {
        double kinetic = 0;
        for (int i = 0; i < 5; ++i) kinetic += v[i] * v[i];
        return kinetic / 2 - p[0] * q[0] * q[1] + p[1] * q[2] * q[4];
      },
      {0.1, -0.2, 0.3, 0.4, -0.5}, {0.2, 0.1, -0.3, 0.5, 0.25});
}

TEST_F(HostileModel, NamesOfGeneratedTemporariesAndKernelArgumentsCannotCapture) {
  // pd_tNNNN are the generator's temporaries; h, t0, t1, q0, q1, p, Ld, D1.. are kernel arguments.
  const std::string text =
      "model capture\n"
      "coords pd_t0000 pd_t0001 h t0 q0 p Ld D1 D12\n"
      "param pd_t0002 = 3\n"
      "param q1 = 0.25\n"
      "L = 1/2*(pd_t0000'^2 + pd_t0001'^2 + h'^2 + t0'^2 + q0'^2 + p'^2 + Ld'^2 + D1'^2 + D12'^2)"
      " - pd_t0002*pd_t0000*pd_t0001 + q1*h*t0*t + sin(q0)*cos(p) + Ld^3 - D1*D12\n";
  const Generated g = generate("capture.lag", text);
  expect_compiled(g);
  if (!g.model) return;
  EXPECT_NE(g.model->time_dependent, 0);
  expect_trapezoid_matches(
      *g.model,
      [](double t, const double* q, const double* v, const double* p) {
        double kinetic = 0;
        for (int i = 0; i < 9; ++i) kinetic += v[i] * v[i];
        return kinetic / 2 - p[0] * q[0] * q[1] + p[1] * q[2] * q[3] * t + std::sin(q[4]) * std::cos(q[5]) +
               q[6] * q[6] * q[6] - q[7] * q[8];
      },
      {0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9}, {-0.1, 0.25, 0.35, 0.1, 0.45, 0.65, 0.6, 0.85, 1.0});
}

/** Model names that are keywords, library names or kernel-argument names. */
class HostileModelName : public reliability::ModelWorkshop, public ::testing::WithParamInterface<std::string> {};

TEST_P(HostileModelName, CompilesAndKeepsItsName) {
  const std::string name = GetParam();
  const std::string text = "model " + name + "\ncoords x\nparam k = 2\nL = 1/2*x'^2 - k/2*x^2\n";
  const Generated g = generate(name + ".lag", text);
  expect_compiled(g);
  if (!g.model) return;
  EXPECT_EQ(std::string(g.model->name), name);
  expect_trapezoid_matches(
      *g.model, [](double, const double* q, const double* v, const double* p) { return v[0] * v[0] / 2 - p[0] / 2 * q[0] * q[0]; },
      {0.3}, {-0.4});
}

INSTANTIATE_TEST_SUITE_P(Names, HostileModelName,
                         ::testing::Values("int", "main", "std", "NULL", "errno", "h", "Ld", "pd_t0001", "x"));

// The generated header declares `extern const pardel_model <name>_model;`, so a model named
// `pardel` declares a variable `pardel_model` that collides with the ABI's typedef of that name:
// pardel-gen accepts the name and the generated C++ does not compile (a defect of pardel-gen: the
// name must be refused with its FILE:LINE:COL or the symbol renamed).
TEST_F(HostileModel, ModelNamedPardelIsRefusedOrCompiles) {
  const std::string text = "model pardel\ncoords x\nL = 1/2*x'^2\n";
  const Generated g = generate("pardel.lag", text);
  if (g.gen_status == 1) {
    EXPECT_EQ(expect_located_rejection(g, text), "1:7");
    return;
  }
  expect_compiled(g);
}

TEST_F(HostileModel, LongestNamesAreAcceptedAndOneMoreIsRefused) {
  const std::string coord(64, 'c');
  const std::string param = "p" + std::string(63, '_');
  const std::string model(48, 'm');
  const std::string text = "model " + model + "\ncoords " + coord + "\nparam " + param + " = 1.5\nL = 1/2*" +
                           coord + "'^2 + " + param + "*" + coord + "\n";
  const Generated g = generate("longest.lag", text);
  expect_compiled(g);
  if (g.model) {
    EXPECT_EQ(std::string(g.model->coords[0]), coord);
    expect_trapezoid_matches(
        *g.model, [](double, const double* q, const double* v, const double* p) { return v[0] * v[0] / 2 + p[0] * q[0]; },
        {1.0}, {2.0});
  }
  const std::string too_long_model = "model " + model + "m\ncoords x\nL = x'^2\n";
  EXPECT_EQ(expect_located_rejection(generate("long_model.lag", too_long_model), too_long_model), "1:7");
  const std::string too_long_coord = "model m\ncoords x " + coord + "c\nL = x'^2\n";
  EXPECT_EQ(expect_located_rejection(generate("long_coord.lag", too_long_coord), too_long_coord), "2:10");
}

TEST_F(HostileModel, MegabyteIdentifierIsRefusedWithItsColumn) {
  const std::string text = "model m\ncoords x\nL = x'^2 + " + std::string(1000000, 'y') + "\n";
  EXPECT_EQ(expect_located_rejection(generate("huge_identifier.lag", text), text), "3:12");
}

// ---------------------------------------------------------------------------------------------
// Bytes

TEST_F(HostileModel, NonAsciiBytesInNamesAndExpressionsAreRefused) {
  const std::string in_name = "model m\ncoords x caf\xc3\xa9\nL = x'^2\n";
  EXPECT_EQ(expect_located_rejection(generate("utf8_name.lag", in_name), in_name), "2:13");
  const std::string in_expression = "model m\ncoords x\nL = x'^2 \xe2\x88\x92 x\n";
  EXPECT_EQ(expect_located_rejection(generate("utf8_minus.lag", in_expression), in_expression), "3:10");
  const std::string high_byte = "model m\xff\ncoords x\nL = x'^2\n";
  EXPECT_EQ(expect_located_rejection(generate("high_byte.lag", high_byte), high_byte), "1:8");
}

TEST_F(HostileModel, NulBytesAreRefusedInCodeAndIgnoredInComments) {
  const std::string in_code = std::string("model m\ncoords x\nL = x'^2 +") + '\0' + " x\n";
  EXPECT_EQ(expect_located_rejection(generate("nul_code.lag", in_code), in_code), "3:11");
  const std::string in_comment = std::string("model nul_comment\ncoords x\nL = 1/2*x'^2 # a") + '\0' + "b\n";
  const Generated g = generate("nul_comment.lag", in_comment);
  expect_compiled(g);
  if (g.model) {
    expect_trapezoid_matches(*g.model, [](double, const double*, const double* v, const double*) { return v[0] * v[0] / 2; },
                             {0.0}, {1.0});
  }
}

TEST_F(HostileModel, CommentsCannotInjectCode) {
  // Preprocessor lines, comment terminators, quotes, a trailing backslash (a line splice if it
  // were copied into a // comment) and a trigraph, all in .lag comments.
  const std::string text =
      "# #include <cstdlib>\n"
      "#define L 0\n"
      "model injected # */ int main() { return 1; } /*\n"
      "coords x # \" unterminated string \\\n"
      "param k = 2 # ?\?/\n"
      "L = 1/2*x'^2 - k*x # \\\n"
      "# last line */ \"\n";
  const Generated g = generate("injected.lag", text);
  expect_compiled(g);
  if (g.model) {
    expect_trapezoid_matches(
        *g.model, [](double, const double* q, const double* v, const double* p) { return v[0] * v[0] / 2 - p[0] * q[0]; },
        {0.5}, {0.75});
  }
}

TEST_F(HostileModel, QuotesBackslashesAndCommentTerminatorsInExpressionsAreRefused) {
  struct Case {
    std::string expression;
    std::string where;
  };
  const std::vector<Case> cases = {{"x'^2 + \"x\"", "3:12"}, {"x'^2 \\ 2", "3:10"}, {"x'^2 */ 2", "3:11"},
                                   {"x'^2 /* x */", "3:11"}, {"x'^2 + #include", "3:11"}, {"x'^2 ; x", "3:10"}};
  for (const Case& c : cases) {
    const std::string text = "model m\ncoords x\nL = " + c.expression + "\n";
    EXPECT_EQ(expect_located_rejection(generate("expr.lag", text), text), c.where) << c.expression;
  }
}

TEST_F(HostileModel, SourcePathWithQuotesAndCommentTerminatorsCompiles) {
  // The .lag path is written into the banner comment and the descriptor's string.
  const std::string text = "model odd_path\ncoords x\nL = 1/2*x'^2\n";
  const Generated g = generate("we\"ird */ ?\?/ \\.lag", text);
  expect_compiled(g);
  if (g.model) EXPECT_EQ(std::string(g.model->source), g.lag_path);
}

// ---------------------------------------------------------------------------------------------
// Sizes and depths

TEST_F(HostileModel, ModerateNestingIsAcceptedAndEvaluatesCorrectly) {
  const std::string text = "model nested\ncoords x\nL = 1/2*x'^2 + " + std::string(150, '(') + "x" +
                           std::string(150, ')') + " + sin(sin(sin(sin(sin(sin(sin(sin(x))))))))\n";
  const Generated g = generate("nested.lag", text);
  expect_compiled(g);
  if (g.model) {
    expect_trapezoid_matches(
        *g.model,
        [](double, const double* q, const double* v, const double*) {
          double s = q[0];
          for (int i = 0; i < 8; ++i) s = std::sin(s);
          return v[0] * v[0] / 2 + q[0] + s;
        },
        {0.7}, {0.2});
  }
}

// 200000 nested parentheses (400 kB, under the reader's 1 MiB file limit): a recursive-descent
// reader without a depth limit overflows its stack here; pardel's must refuse with FILE:LINE:COL.
TEST_F(HostileModel, DeepNestingIsRefusedWithoutACrash) {
  const std::string text = "model m\ncoords x\nL = x'^2 + " + std::string(200000, '(') + "x" +
                           std::string(200000, ')') + "\n";
  expect_located_rejection(generate("deep.lag", text), text);
}

// The same depth through unary minus: one recursion per sign.
TEST_F(HostileModel, LongUnaryMinusChainIsRefusedOrAcceptedWithoutACrash) {
  const std::string text = "model minus_chain\ncoords x\nL = x'^2 + " + std::string(500000, '-') + "x\n";
  const Generated g = generate("minus_chain.lag", text);
  if (g.gen_status == 0) {
    expect_compiled(g);
  } else {
    expect_located_rejection(g, text);
  }
}

TEST_F(HostileModel, MegabyteLineIsAcceptedAndEvaluatesCorrectly) {
  // About 10^6 characters: L = x'^2/2 + x + x + ... (250000 terms).
  std::string sum;
  const int terms = 250000;
  sum.reserve(static_cast<std::size_t>(terms) * 4);
  for (int i = 0; i < terms; ++i) sum += i ? " + x" : "x";
  const std::string text = "model long_line\ncoords x\nL = 1/2*x'^2 + " + sum + "\n";
  ASSERT_GE(text.size(), 1000000u);
  const Generated g = generate("long_line.lag", text);
  expect_compiled(g);
  if (g.model) {
    expect_trapezoid_matches(
        *g.model, [terms](double, const double* q, const double* v, const double*) { return v[0] * v[0] / 2 + terms * q[0]; },
        {0.5}, {-0.25});
  }
}

TEST_F(HostileModel, MegabyteCommentAndGarbageLinesAreHandled) {
  const std::string comment = "model long_comment\ncoords x\n#" + std::string(1000000, '*') + "\nL = 1/2*x'^2\n";
  expect_compiled(generate("long_comment.lag", comment));
  const std::string garbage = "model m\ncoords x\nL = x'^2 " + std::string(1000000, '@') + "\n";
  EXPECT_EQ(expect_located_rejection(generate("garbage.lag", garbage), garbage), "3:10");
}

TEST_F(HostileModel, FileOverOneMebibyteIsRefused) {
  const std::string text = "model m\ncoords x\nL = x'^2\n#" + std::string(1u << 20, 'x') + "\n";
  EXPECT_EQ(expect_located_rejection(generate("too_big.lag", text), text), "1:1");
}

// ---------------------------------------------------------------------------------------------
// Numbers

TEST_F(HostileModel, LargeButFiniteConstantsAndPowersEvaluateCorrectly) {
  const std::string text = "model big_numbers\ncoords x\nparam a = 1e300\n"
                           "L = 1/2*x'^2 + x^1000 + a*1e-300*x + 12345678901234567890123456789*x^2/1e28\n";
  const Generated g = generate("big_numbers.lag", text);
  expect_compiled(g);
  if (g.model) {
    EXPECT_EQ(g.model->param_defaults[0], 1e300);
    expect_trapezoid_matches(
        *g.model,
        [](double, const double* q, const double* v, const double* p) {
          return v[0] * v[0] / 2 + std::pow(q[0], 1000) + p[0] * 1e-300 * q[0] + 1.2345678901234567890123456789 * q[0] * q[0];
        },
        {1.0005}, {0.999});
  }
}

TEST_F(HostileModel, OutOfRangeNumbersAreRefusedWithTheirColumn) {
  const std::string beyond_double = "model m\ncoords x\nL = x'^2 + 1e309\n";
  EXPECT_EQ(expect_located_rejection(generate("e309.lag", beyond_double), beyond_double), "3:12");
  const std::string param_overflow = "model m\ncoords x\nparam a = 1e308*10\nL = x'^2 + a\n";
  EXPECT_EQ(expect_located_rejection(generate("param_inf.lag", param_overflow), param_overflow), "3:11");
  const std::string division = "model m\ncoords x\nL = x'^2 + x/(1 - 1)\n";
  EXPECT_EQ(expect_located_rejection(generate("div0.lag", division), division), "3:13");
}

// An exponent beyond the range of long ("1e99999999999999999999") makes std::stol throw
// std::out_of_range inside the reader (codegen/src/lag_expression.cpp, number_value), which
// pardel-gen reports as "internal error of pardel-gen: stol" without a position. A defect:
// the number must be refused as out of range at its FILE:LINE:COL.
TEST_F(HostileModel, ExponentBeyondLongIsRefusedWithItsColumn) {
  const std::string text = "model m\ncoords x\nL = x'^2 + 1e99999999999999999999\n";
  EXPECT_EQ(expect_located_rejection(generate("e_huge.lag", text), text), "3:12");
}

// 2^(10^308) is evaluated exactly by GiNaC inside the reader (an integer of ~10^308 bits): the
// reader never returns. A defect of the .lag reader: exact powers of numbers with huge exponents
// must be refused with FILE:LINE:COL (or evaluated in floating point).
TEST_F(HostileModel, HugeIntegerPowerIsRefusedWithinSeconds) {
  const std::string text = "model m\ncoords x\nL = x'^2 + 2^(10^308)\n";
  expect_located_rejection(generate("pow_huge.lag", text, 20), text);
}

TEST_F(HostileModel, SymbolicPowerWithHugeExponentIsRefusedCleanly) {
  // x^(10^308): the derivative's coefficient 10^308 * (10^308 - 1) is not a finite double.
  const std::string text = "model m\ncoords x\nL = x'^2 + x^(10^308)\n";
  const Generated g = generate("xpow_huge.lag", text);
  EXPECT_EQ(g.gen_status, 1) << g.gen_stderr;
  EXPECT_EQ(g.gen_stderr.rfind(g.lag_path + ":", 0), 0u) << g.gen_stderr;
  EXPECT_NE(g.gen_stderr.find("error: "), std::string::npos) << g.gen_stderr;
}

// Constants that are valid while reading but not as double arithmetic (x^(10^308), whose second
// derivative has the factor 10^616; log(-1) = i pi) are found by the code generator after
// parsing; the refusal names the power or the call that causes it.
TEST_F(HostileModel, GeneratorRefusalsNameLineAndColumn) {
  const std::string huge = "model m\ncoords x\nL = x'^2 + x^(10^308)\n";
  EXPECT_EQ(expect_located_rejection(generate("xpow_huge.lag", huge), huge), "3:13");
  const std::string complex = "model m\ncoords x\nL = x'^2 + log(-1)*x\n";
  EXPECT_EQ(expect_located_rejection(generate("complex.lag", complex), complex), "3:12");
  // Inside a let: the position in the let's line.
  const std::string in_let = "model m\ncoords x\nlet a = 2*acos(3)\nL = x'^2 + a*x\n";
  EXPECT_EQ(expect_located_rejection(generate("in_let.lag", in_let), in_let), "3:11");
  // In the clock.
  const std::string in_clock = "model m\ncoords x\nL = x'^2/2\nclock = 1 + log(-1)*x\n";
  EXPECT_EQ(expect_located_rejection(generate("in_clock.lag", in_clock), in_clock), "4:13");
  // No single power or call is at fault (10^200 * 10^200 overflows): the expression's start.
  const std::string product = "model m\ncoords x\nL = x'^2 + 10^200*10^200*x\n";
  EXPECT_EQ(expect_located_rejection(generate("product.lag", product), product), "3:5");
  // The innermost offending term: sqrt(-4) inside sin(...).
  const std::string nested = "model m\ncoords x\nL = x'^2 + sin(x + sqrt(-4))\n";
  EXPECT_EQ(expect_located_rejection(generate("nested.lag", nested), nested), "3:20");
}

}  // namespace
