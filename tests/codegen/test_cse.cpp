// Tests of the common-subexpression elimination and C printing: the emitted text, read back by
// a small independent evaluator, equals GiNaC's evaluation of the input expressions at random
// points; names are deterministic; operation counts drop; powers, negations and shared
// sub-sums are emitted as documented; bad expressions are reported.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "pardel_codegen/cse.hpp"
#include "pardel_codegen/discretize.hpp"
#include "pardel_codegen/lag_parser.hpp"

namespace {

using pardel_codegen::CseOptions;
using pardel_codegen::KernelCode;
using pardel_codegen::KernelInput;
using pardel_codegen::KernelOutput;

/** Evaluates the C expressions pardel-gen prints (doubles, + - * /, unary -, std:: calls). */
class CEvaluator {
 public:
  explicit CEvaluator(std::map<std::string, double> vars) : vars_(std::move(vars)) {}

  /** Runs the temporaries, then returns the value of every output. */
  std::vector<double> run(const KernelCode& code) {
    for (const auto& t : code.temporaries) vars_[t.name] = eval(t.expr);
    std::vector<double> out;
    for (const auto& o : code.outputs) out.push_back(eval(o.expr));
    return out;
  }

  double eval(const std::string& text) {
    s_ = text;
    i_ = 0;
    double v = sum();
    skip();
    if (i_ != s_.size()) throw std::runtime_error("trailing text in '" + s_ + "'");
    return v;
  }

 private:
  void skip() {
    while (i_ < s_.size() && s_[i_] == ' ') ++i_;
  }
  bool eat(char c) {
    skip();
    if (i_ < s_.size() && s_[i_] == c) {
      ++i_;
      return true;
    }
    return false;
  }
  double sum() {
    double v = product();
    for (;;) {
      if (eat('+')) v += product();
      else if (eat('-')) v -= product();
      else return v;
    }
  }
  double product() {
    double v = unary();
    for (;;) {
      if (eat('*')) v *= unary();
      else if (eat('/')) v /= unary();
      else return v;
    }
  }
  double unary() {
    if (eat('-')) return -unary();
    return primary();
  }
  double primary() {
    skip();
    if (eat('(')) {
      double v = sum();
      if (!eat(')')) throw std::runtime_error("missing ')' in '" + s_ + "'");
      return v;
    }
    if (i_ < s_.size() && (std::isdigit(static_cast<unsigned char>(s_[i_])) || s_[i_] == '.')) {
      std::size_t used = 0;
      double v = std::stod(s_.substr(i_), &used);
      i_ += used;
      return v;
    }
    std::size_t j = i_;
    while (j < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[j])) || s_[j] == '_' || s_[j] == ':')) ++j;
    std::string name = s_.substr(i_, j - i_);
    if (name.empty()) throw std::runtime_error("unexpected text in '" + s_ + "'");
    i_ = j;
    if (eat('[')) {
      std::size_t close = s_.find(']', i_);
      name += "[" + s_.substr(i_, close - i_) + "]";
      i_ = close + 1;
    }
    if (name.rfind("std::", 0) == 0) {
      if (!eat('(')) throw std::runtime_error("call without '('");
      std::vector<double> args{sum()};
      while (eat(',')) args.push_back(sum());
      if (!eat(')')) throw std::runtime_error("call without ')'");
      return call(name.substr(5), args);
    }
    auto it = vars_.find(name);
    if (it == vars_.end()) throw std::runtime_error("unknown name '" + name + "'");
    return it->second;
  }
  static double call(const std::string& f, const std::vector<double>& a) {
    if (f == "sin") return std::sin(a[0]);
    if (f == "cos") return std::cos(a[0]);
    if (f == "tan") return std::tan(a[0]);
    if (f == "exp") return std::exp(a[0]);
    if (f == "log") return std::log(a[0]);
    if (f == "sqrt") return std::sqrt(a[0]);
    if (f == "sinh") return std::sinh(a[0]);
    if (f == "cosh") return std::cosh(a[0]);
    if (f == "tanh") return std::tanh(a[0]);
    if (f == "asin") return std::asin(a[0]);
    if (f == "acos") return std::acos(a[0]);
    if (f == "atan") return std::atan(a[0]);
    if (f == "atan2") return std::atan2(a[0], a[1]);
    if (f == "pow") return std::pow(a[0], a[1]);
    throw std::runtime_error("unknown function " + f);
  }
  std::map<std::string, double> vars_;
  std::string s_;
  std::size_t i_ = 0;
};

struct Fixture {
  std::vector<GiNaC::symbol> x;
  std::vector<KernelInput> inputs;
  Fixture() {
    for (int i = 0; i < 4; ++i) {
      x.emplace_back("x" + std::to_string(i));
      inputs.push_back({x.back(), "x[" + std::to_string(i) + "]", "x"});
    }
  }
};

/** A random expression over the fixture's symbols, with values kept in the functions' domains. */
GiNaC::ex random_expression(const Fixture& f, std::mt19937& rng, int depth) {
  std::uniform_int_distribution<int> pick(0, 11);
  std::uniform_int_distribution<int> var(0, 3);
  std::uniform_int_distribution<int> small(1, 5);
  if (depth == 0) {
    int k = pick(rng) % 3;
    if (k == 0) return GiNaC::numeric(small(rng), small(rng));
    return f.x[var(rng)];
  }
  GiNaC::ex a = random_expression(f, rng, depth - 1);
  GiNaC::ex b = random_expression(f, rng, depth - 1);
  switch (pick(rng)) {
    case 0: return a + b;
    case 1: return a - b;
    case 2: return a * b;
    case 3: return a / (2 + b * b);
    case 4: return GiNaC::pow(a, small(rng) - 2);
    case 5: return GiNaC::sin(a) * b;
    case 6: return GiNaC::cos(a - b);
    case 7: return GiNaC::exp(a / 4);
    case 8: return GiNaC::sqrt(1 + a * a);
    case 9: return GiNaC::log(3 + GiNaC::sin(b));
    case 10: return GiNaC::atan(a) - GiNaC::numeric(1, 3) * b;
    default: return a * a + b;
  }
}

double ginac_value(const GiNaC::ex& e, const Fixture& f, const std::vector<double>& at) {
  GiNaC::exmap m;
  for (int i = 0; i < 4; ++i) m[f.x[i]] = GiNaC::numeric(at[i]);
  GiNaC::ex v = e.subs(m).evalf();
  return GiNaC::ex_to<GiNaC::numeric>(v).to_double();
}

TEST(Cse, EmittedCodeEqualsGinacOnRandomExpressionsAndDerivatives) {
  Fixture f;
  std::mt19937 rng(12345u);
  std::uniform_real_distribution<double> unit(-1.5, 1.5);
  for (int trial = 0; trial < 40; ++trial) {
    std::vector<KernelOutput> outs;
    GiNaC::ex e = random_expression(f, rng, 4);
    outs.push_back({"y[0]", e});
    for (int i = 0; i < 4; ++i) outs.push_back({"y[" + std::to_string(i + 1) + "]", e.diff(f.x[i])});
    outs.push_back({"y[5]", e.diff(f.x[0]).diff(f.x[1])});
    KernelCode code;
    try {
      code = pardel_codegen::generate_kernel_code(outs, f.inputs);
    } catch (const pardel_codegen::CodegenError&) {
      continue;  // a constant subexpression such as log(0) is rejected, which is also tested below
    }
    EXPECT_LE(code.ops_after, code.ops_before);
    for (int point = 0; point < 3; ++point) {
      std::vector<double> at = {unit(rng), unit(rng), unit(rng), unit(rng)};
      std::map<std::string, double> vars;
      for (int i = 0; i < 4; ++i) vars["x[" + std::to_string(i) + "]"] = at[i];
      CEvaluator evaluator(vars);
      std::vector<double> got = evaluator.run(code);
      for (std::size_t k = 0; k < outs.size(); ++k) {
        const double want = ginac_value(outs[k].value, f, at);
        if (!std::isfinite(want)) continue;
        EXPECT_NEAR(got[k], want, 1e-9 * std::max(1.0, std::fabs(want)))
            << "trial " << trial << " output " << k << ": " << outs[k].value;
      }
    }
  }
}

TEST(Cse, OutputIsDeterministicAndTemporariesAreNumberedInOrder) {
  Fixture f;
  std::mt19937 rng(777u);
  GiNaC::ex e = random_expression(f, rng, 5);
  std::vector<KernelOutput> outs = {{"a", e}, {"b", e.diff(f.x[0])}, {"c", e.diff(f.x[1])}};
  KernelCode one = pardel_codegen::generate_kernel_code(outs, f.inputs);
  KernelCode two = pardel_codegen::generate_kernel_code(outs, f.inputs);
  ASSERT_EQ(one.temporaries.size(), two.temporaries.size());
  for (std::size_t i = 0; i < one.temporaries.size(); ++i) {
    char expected[16];
    std::snprintf(expected, sizeof expected, "pd_t%04zu", i + 1);
    EXPECT_EQ(one.temporaries[i].name, expected);
    EXPECT_EQ(one.temporaries[i].name, two.temporaries[i].name);
    EXPECT_EQ(one.temporaries[i].expr, two.temporaries[i].expr);
  }
  for (std::size_t i = 0; i < one.outputs.size(); ++i) EXPECT_EQ(one.outputs[i].expr, two.outputs[i].expr);
}

TEST(Cse, SharedSubexpressionsAreComputedOnce) {
  Fixture f;
  const GiNaC::ex& x = f.x[0];
  const GiNaC::ex& y = f.x[1];
  GiNaC::ex shared = GiNaC::sin(x * y + 1);
  KernelCode code = pardel_codegen::generate_kernel_code({{"a", shared * x}, {"b", shared * y}, {"c", shared}},
                                                         f.inputs);
  // x*y, +1, sin: 3 operations shared; two products: 2 more.
  EXPECT_EQ(code.ops_after, 5);
  EXPECT_EQ(code.ops_before, 3 + 4 + 4);
  EXPECT_EQ(code.outputs[2].expr, code.temporaries.back().name);
}

TEST(Cse, IntegerPowersBecomeMultiplicationsThatReuseSquares) {
  Fixture f;
  const GiNaC::ex& x = f.x[0];
  KernelCode p4 = pardel_codegen::generate_kernel_code({{"a", GiNaC::pow(x, 4)}}, f.inputs);
  EXPECT_EQ(p4.ops_after, 2);  // s = x*x; s*s
  KernelCode inv = pardel_codegen::generate_kernel_code({{"a", GiNaC::pow(x, -1)}}, f.inputs);
  EXPECT_EQ(inv.ops_after, 1);
  EXPECT_EQ(inv.outputs[0].expr, "1.0/x[0]");
  KernelCode both = pardel_codegen::generate_kernel_code({{"a", GiNaC::pow(x, 2)}, {"b", GiNaC::pow(x, 3)}}, f.inputs);
  EXPECT_EQ(both.ops_after, 2);  // x*x, then (x*x)*x
}

TEST(Cse, NegationsFoldIntoSubtractions) {
  Fixture f;
  const GiNaC::ex& x = f.x[0];
  const GiNaC::ex& y = f.x[1];
  const GiNaC::ex& z = f.x[2];
  KernelCode code = pardel_codegen::generate_kernel_code({{"a", z - x * y}}, f.inputs);
  EXPECT_EQ(code.ops_after, 2);
  KernelCode odd = pardel_codegen::generate_kernel_code({{"a", GiNaC::sin(y - x) + GiNaC::cos(y - x)}}, f.inputs);
  EXPECT_LE(odd.ops_after, 4);  // x - y once, sin, cos, one subtraction
}

TEST(Cse, FactoringFindsSharedPartialSums) {
  Fixture f;
  const GiNaC::ex a = GiNaC::sin(f.x[0]), b = GiNaC::cos(f.x[1]), c = GiNaC::exp(f.x[2]), d = f.x[3];
  std::vector<KernelOutput> outs = {{"u", GiNaC::log(a + b + c)}, {"v", GiNaC::log(a + b + d)},
                                    {"w", GiNaC::log(2 * a + 2 * b + c * d)}};
  CseOptions off;
  off.factor_sums = false;
  off.factor_products = false;
  KernelCode plain = pardel_codegen::generate_kernel_code(outs, f.inputs, off);
  KernelCode factored = pardel_codegen::generate_kernel_code(outs, f.inputs);
  EXPECT_LT(factored.ops_after, plain.ops_after);
  // sin, cos, exp, c*d, a+b, +c, +d, 2*(a+b), +c*d, three logs.
  EXPECT_EQ(factored.ops_after, 12);
}

TEST(Cse, FactoringFindsSharedPartialProducts) {
  Fixture f;
  const GiNaC::ex a = GiNaC::sin(f.x[0]), b = GiNaC::cos(f.x[1]), c = f.x[2], d = f.x[3];
  std::vector<KernelOutput> outs = {{"u", a * b * c}, {"v", a * b * d}, {"w", GiNaC::pow(a * b, 2) * c * d}};
  KernelCode code = pardel_codegen::generate_kernel_code(outs, f.inputs);
  // sin, cos, a*b, *c, *d, (a*b)^2, c*d, product: 8.
  EXPECT_EQ(code.ops_after, 8);
}

TEST(Cse, ConstantsAreFoldedAndPrintedWithFullPrecision) {
  Fixture f;
  KernelCode code = pardel_codegen::generate_kernel_code(
      {{"a", GiNaC::sqrt(GiNaC::ex(3)) / 6 * f.x[0]}, {"b", GiNaC::ex(GiNaC::numeric(2, 3))}, {"c", GiNaC::ex(0)}},
      f.inputs);
  EXPECT_EQ(code.ops_after, 1);
  EXPECT_EQ(code.outputs[1].expr, "0.66666666666666663");
  EXPECT_EQ(code.outputs[2].expr, "0.0");
  EXPECT_EQ(pardel_codegen::c_double_literal(2.0), "2.0");
  EXPECT_EQ(pardel_codegen::c_double_literal(1e300), "1.0000000000000001e+300");
  EXPECT_THROW(pardel_codegen::c_double_literal(INFINITY), pardel_codegen::CodegenError);
}

TEST(Cse, ReportsExpressionsThatCannotBeEmitted) {
  Fixture f;
  GiNaC::symbol stranger("stranger");
  EXPECT_THROW(pardel_codegen::generate_kernel_code({{"a", stranger * f.x[0]}}, f.inputs),
               pardel_codegen::CodegenError);
  EXPECT_THROW(pardel_codegen::generate_kernel_code({{"a", GiNaC::sqrt(GiNaC::ex(-2)) * f.x[0]}}, f.inputs),
               pardel_codegen::CodegenError);
  EXPECT_THROW(pardel_codegen::generate_kernel_code({{"a", GiNaC::abs(f.x[0])}}, f.inputs),
               pardel_codegen::CodegenError);
}

TEST(Cse, ReportsTheInputsItReads) {
  Fixture f;
  KernelCode code = pardel_codegen::generate_kernel_code({{"a", f.x[0] * f.x[0]}}, f.inputs);
  EXPECT_EQ(code.used_groups, std::set<std::string>{"x"});
  KernelCode none = pardel_codegen::generate_kernel_code({{"a", GiNaC::ex(1)}}, f.inputs);
  EXPECT_TRUE(none.used_groups.empty());
}

// Factoring (a + b) out of X = k a + k b + c makes X identical to Y = k (a + b) + c; the merge of
// such duplicates between rounds must then also merge the terms and factors that held both.
TEST(Cse, NodesMadeIdenticalByFactoringMergeCorrectly) {
  Fixture f;
  const GiNaC::ex a = GiNaC::sin(f.x[0]), b = GiNaC::cos(f.x[1]), c = GiNaC::exp(f.x[2]), d = f.x[3];
  const GiNaC::ex k = GiNaC::sqrt(GiNaC::ex(3));
  const GiNaC::ex X = k * a + k * b + c;
  const GiNaC::ex Y = k * (a + b) + c;
  const GiNaC::ex u = GiNaC::sqrt(GiNaC::ex(2)), w = GiNaC::sqrt(GiNaC::ex(5));
  std::vector<KernelOutput> outs = {{"o1", GiNaC::sin(a + b)}, {"o2", u * X + w * Y},
                                    {"o3", u * X + w * Y + d},  {"o4", X * Y * d},
                                    {"o5", X * Y * (d + 1)},    {"o6", GiNaC::log(X) + GiNaC::log(Y)}};
  const KernelCode code = pardel_codegen::generate_kernel_code(outs, f.inputs);
  const std::vector<double> at = {0.3, -0.4, 0.2, 0.7};
  std::map<std::string, double> vars;
  for (int i = 0; i < 4; ++i) vars["x[" + std::to_string(i) + "]"] = at[static_cast<std::size_t>(i)];
  const std::vector<double> got = CEvaluator(vars).run(code);
  for (std::size_t i = 0; i < outs.size(); ++i) {
    const double want = ginac_value(outs[i].value, f, at);
    EXPECT_NEAR(got[i], want, 1e-12 * std::max(1.0, std::fabs(want))) << outs[i].target;
  }
}

// Factoring rewrites the DAG in place and merges duplicates between rounds; on the derivatives
// of a real discrete Lagrangian (many shared sums) the factored code must compute the same
// values as the plain hash-consed code.
TEST(Cse, FactoringPreservesValuesOnDiscreteLagrangianDerivatives) {
  pardel_codegen::LagModel model = pardel_codegen::parse_lag(
      "model m\norder 2\ncoords x y\nparam c = 3\nlet W = cos(2*x - y - 6)\n"
      "L = 1/2*((x' - W)^2 + (y' - sin(y))^2 + c*(x'' + W*x' - y*y')^2 + c*y''^2)\n"
      "discretizations gauss2\n",
      "m.lag");
  pardel_codegen::KernelSymbols s(model);
  const GiNaC::ex Ld = pardel_codegen::discrete_lagrangian(model, model.discretizations[0], s);
  std::vector<KernelInput> inputs = {{s.h, "h", "h"}, {s.t0, "t0", "t0"}, {s.t1, "t1", "t1"}, {s.p[0], "p[0]", "p"}};
  std::map<std::string, double> at = {{"h", 0.1}, {"t0", 0.0}, {"t1", 0.1}, {"p[0]", 3.0}};
  for (std::size_t i = 0; i < s.q0.size(); ++i) {
    inputs.push_back({s.q0[i], "q0[" + std::to_string(i) + "]", "q0"});
    inputs.push_back({s.q1[i], "q1[" + std::to_string(i) + "]", "q1"});
    at["q0[" + std::to_string(i) + "]"] = 0.3 + 0.1 * static_cast<double>(i);
    at["q1[" + std::to_string(i) + "]"] = 0.35 + 0.12 * static_cast<double>(i);
  }
  std::vector<KernelOutput> outs = {{"Ld", Ld}};
  for (std::size_t i = 0; i < s.q0.size(); ++i) {
    const GiNaC::ex d1 = Ld.diff(s.q0[i]);
    outs.push_back({"D1", d1});
    for (std::size_t j = 0; j < s.q0.size(); ++j) {
      outs.push_back({"D11", d1.diff(s.q0[j])});
      outs.push_back({"D12", d1.diff(s.q1[j])});
    }
  }
  CseOptions off;
  off.factor_sums = false;
  off.factor_products = false;
  const KernelCode plain = pardel_codegen::generate_kernel_code(outs, inputs, off);
  const KernelCode factored = pardel_codegen::generate_kernel_code(outs, inputs);
  EXPECT_LT(factored.ops_after, plain.ops_after);
  const std::vector<double> want = CEvaluator(at).run(plain);
  const std::vector<double> got = CEvaluator(at).run(factored);
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t k = 0; k < got.size(); ++k) {
    EXPECT_NEAR(got[k], want[k], 1e-10 * std::max(1.0, std::fabs(want[k]))) << outs[k].target << " #" << k;
  }
}

}  // namespace
