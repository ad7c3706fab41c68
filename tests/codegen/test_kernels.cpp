// Tests of the generated kernels of every test model (tests/codegen/models) and every bundled
// model (lagrangians/): each kernel against GiNaC's own evaluation of the same derivatives (no
// CSE) and against central finite differences of L_d, the variants against each other, the clock,
// and the model descriptor against the .lag. The generated sources are compiled with
// -Wall -Wextra -Werror (see CMakeLists.txt).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "pardel/extended_kernels.hpp"  // PD_HAVE_QUADMATH: the precision of the extended kernels
#include "generated_models.hpp"
#include "pardel_codegen/discretize.hpp"
#include "pardel_codegen/lag_parser.hpp"

namespace {

using pardel_codegen::KernelSymbols;
using pardel_codegen::LagModel;

/** One evaluation point of a kernel. */
struct Point {
  double h = 0, t0 = 0, t1 = 0;
  std::vector<double> q0, q1, p;
};

/** Everything a full kernel returns. */
struct Values {
  double Ld = 0;
  std::vector<double> D1, D2, D11, D12, D22;
  explicit Values(int m) : D1(m), D2(m), D11(m * m), D12(m * m), D22(m * m) {}
};

Values run_full(const pardel_discretization& d, int m, const Point& x) {
  Values v(m);
  d.full(x.h, x.t0, x.t1, x.q0.data(), x.q1.data(), x.p.data(), &v.Ld, v.D1.data(), v.D2.data(), v.D11.data(),
         v.D12.data(), v.D22.data());
  return v;
}

Point random_point(const pardel_model& model, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const int n = model.ncoords, m = model.dim;
  Point x;
  x.h = 0.05 + 0.1 * (unit(rng) + 1.0);
  x.t0 = 0.5 + 0.5 * unit(rng);
  x.t1 = x.t0 + 1.25 * x.h;  // t1 - t0 differs from h on purpose
  x.q0.resize(m);
  x.q1.resize(m);
  for (int i = 0; i < n; ++i) {
    x.q0[i] = 0.75 + 0.4 * unit(rng);
    x.q1[i] = x.q0[i] + x.h * unit(rng);
  }
  for (int i = n; i < m; ++i) {
    x.q0[i] = unit(rng);
    x.q1[i] = unit(rng);
  }
  for (int j = 0; j < model.nparams; ++j) x.p.push_back(model.param_defaults[j]);
  return x;
}

GiNaC::exmap substitution(const KernelSymbols& s, const Point& x) {
  GiNaC::exmap m;
  m[s.h] = GiNaC::numeric(x.h);
  m[s.t0] = GiNaC::numeric(x.t0);
  m[s.t1] = GiNaC::numeric(x.t1);
  for (std::size_t i = 0; i < s.q0.size(); ++i) {
    m[s.q0[i]] = GiNaC::numeric(x.q0[i]);
    m[s.q1[i]] = GiNaC::numeric(x.q1[i]);
  }
  for (std::size_t j = 0; j < s.p.size(); ++j) m[s.p[j]] = GiNaC::numeric(x.p[j]);
  return m;
}

double ginac_value(const GiNaC::ex& e, const GiNaC::exmap& at) {
  GiNaC::ex v = e.subs(at, GiNaC::subs_options::no_pattern).evalf();
  if (!GiNaC::is_a<GiNaC::numeric>(v) || !GiNaC::ex_to<GiNaC::numeric>(v).is_real()) {
    ADD_FAILURE() << "GiNaC did not evaluate to a real number: " << v;
    return NAN;
  }
  return GiNaC::ex_to<GiNaC::numeric>(v).to_double();
}

/** The size of an expression printed as a tree (its DAG walked once, with memoized sizes). */
double tree_size(const GiNaC::ex& e, std::map<GiNaC::ex, double, GiNaC::ex_is_less>& memo) {
  auto it = memo.find(e);
  if (it != memo.end()) return it->second;
  double size = 1;
  for (std::size_t i = 0; i < e.nops(); ++i) size += tree_size(e.op(i), memo);
  memo.emplace(e, size);
  return size;
}

/** GiNaC evaluates without sharing, so entries larger than this are left to the
 *  finite-difference test (every entry of every model passes that one). */
constexpr double kMaxTreeForGinac = 2e5;

double scale_of(const std::vector<double>& v) {
  double s = 1.0;
  for (double x : v) s = std::max(s, std::fabs(x));
  return s;
}

void expect_close(const std::vector<double>& got, const std::vector<double>& want, double rel, const std::string& what) {
  ASSERT_EQ(got.size(), want.size());
  const double tol = rel * scale_of(want);
  for (std::size_t i = 0; i < got.size(); ++i) {
    if (std::isnan(want[i])) continue;  // not computed by the reference
    EXPECT_NEAR(got[i], want[i], tol) << what << "[" << i << "]";
  }
}

class GeneratedKernels : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    entry_ = kGeneratedModels[GetParam()];
    lag_ = pardel_codegen::parse_lag_file(entry_.lag_path);
  }
  GeneratedModel entry_{};
  LagModel lag_;
};

TEST_P(GeneratedKernels, DescriptorMatchesTheLagFile) {
  const pardel_model& m = *entry_.model;
  EXPECT_EQ(m.abi_version, PARDEL_KERNEL_ABI_VERSION);
  EXPECT_EQ(std::string(m.name), lag_.name);
  EXPECT_EQ(std::string(m.source), std::string(entry_.source_name));
  EXPECT_EQ(m.order, lag_.order);
  EXPECT_EQ(m.ncoords, lag_.ncoords());
  EXPECT_EQ(m.dim, lag_.order * lag_.ncoords());
  for (int i = 0; i < m.ncoords; ++i) EXPECT_EQ(std::string(m.coords[i]), lag_.coords[i]);
  ASSERT_EQ(m.nparams, static_cast<int>(lag_.params.size()));
  for (int j = 0; j < m.nparams; ++j) {
    EXPECT_EQ(std::string(m.param_names[j]), lag_.params[j].name);
    EXPECT_EQ(m.param_defaults[j], lag_.params[j].default_value);
  }
  EXPECT_EQ(m.time_dependent != 0, lag_.time_dependent());
  EXPECT_EQ(m.clock != nullptr, lag_.has_clock);
  ASSERT_EQ(m.ndiscretizations, static_cast<int>(lag_.discretizations.size()));
  for (int d = 0; d < m.ndiscretizations; ++d) {
    const pardel_discretization& disc = m.discretizations[d];
    EXPECT_EQ(std::string(disc.name), lag_.discretizations[d].name);
    EXPECT_EQ(disc.consistency_order, lag_.discretizations[d].consistency_order);
    EXPECT_NE(disc.full, nullptr);
    EXPECT_NE(disc.sweep, nullptr);
    EXPECT_NE(disc.grad, nullptr);
    EXPECT_NE(disc.action, nullptr);
  }
}

/** A Galerkin discretization with interior values: GiNaC solves dS/dz = 0 by Newton's method in
 *  30-digit arithmetic from the interval's symbolic action, and Ld = S(z*), D1 = dS/dq0 (z*),
 *  D2 = dS/dq1 (z*) (the envelope theorem) must match the condensed kernel. Its second
 *  derivatives are checked by finite differences below. */
void check_condensed_against_ginac(const pardel_model& model, const pardel_discretization& disc, const LagModel& lag,
                                   const pardel_codegen::DiscretizationSpec& spec, const KernelSymbols& s,
                                   std::mt19937& rng) {
  const int m = model.dim;
  const pardel_codegen::GalerkinInterval gi = pardel_codegen::galerkin_interval(lag, spec, s);
  const unsigned M = static_cast<unsigned>(gi.z.size());
  std::vector<GiNaC::ex> gz(M), hz(M * M);
  for (unsigned i = 0; i < M; ++i) gz[i] = gi.action.diff(gi.z[i]);
  for (unsigned i = 0; i < M; ++i)
    for (unsigned j = 0; j < M; ++j) hz[i * M + j] = gz[i].diff(gi.z[j]);
  auto number = [](const GiNaC::ex& e, const GiNaC::exmap& at) {
    return GiNaC::ex_to<GiNaC::numeric>(e.subs(at, GiNaC::subs_options::no_pattern).evalf());
  };
  for (int trial = 0; trial < 2; ++trial) {
    const Point x = random_point(model, rng);
    GiNaC::exmap at = substitution(s, x);
    std::vector<GiNaC::numeric> z(M);
    for (unsigned i = 0; i < M; ++i) z[i] = number(gi.start[i], at);
    for (int it = 0; it < 30; ++it) {
      for (unsigned i = 0; i < M; ++i) at[gi.z[i]] = z[i];
      GiNaC::matrix H(M, M), g(M, 1);
      for (unsigned i = 0; i < M; ++i) {
        g(i, 0) = number(gz[i], at);
        for (unsigned j = 0; j < M; ++j) H(i, j) = number(hz[i * M + j], at);
      }
      const GiNaC::matrix step = H.inverse().mul(g);
      for (unsigned i = 0; i < M; ++i) z[i] -= GiNaC::ex_to<GiNaC::numeric>(step(i, 0).evalf());
    }
    for (unsigned i = 0; i < M; ++i) at[gi.z[i]] = z[i];
    const Values k = run_full(disc, m, x);
    Values g(m);
    g.Ld = ginac_value(gi.action, at);
    for (int i = 0; i < m; ++i) {
      g.D1[i] = ginac_value(gi.action.diff(s.q0[i]), at);
      g.D2[i] = ginac_value(gi.action.diff(s.q1[i]), at);
    }
    expect_close({k.Ld}, {g.Ld}, 1e-10, "Ld (condensed)");
    expect_close(k.D1, g.D1, 1e-10, "D1 (condensed)");
    expect_close(k.D2, g.D2, 1e-10, "D2 (condensed)");
  }
}

TEST_P(GeneratedKernels, FullKernelMatchesGinacDerivatives) {
  const pardel_model& model = *entry_.model;
  const int m = model.dim;
  KernelSymbols s(lag_);
  std::mt19937 rng(20240611u + static_cast<unsigned>(GetParam()));
  GiNaC::Digits = 30;
  long checked = 0, skipped = 0;
  for (int d = 0; d < model.ndiscretizations; ++d) {
    SCOPED_TRACE(model.discretizations[d].name);
    if (lag_.discretizations[d].interior_points > 0) {
      check_condensed_against_ginac(model, model.discretizations[d], lag_, lag_.discretizations[d], s, rng);
      continue;
    }
    const GiNaC::ex Ld = pardel_codegen::discrete_lagrangian(lag_, lag_.discretizations[d], s);
    std::vector<GiNaC::ex> D1, D2, D11, D12, D22;
    for (int i = 0; i < m; ++i) {
      D1.push_back(Ld.diff(s.q0[i]));
      D2.push_back(Ld.diff(s.q1[i]));
    }
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < m; ++j) {
        D11.push_back(D1[i].diff(s.q0[j]));
        D12.push_back(D1[i].diff(s.q1[j]));
        D22.push_back(D2[i].diff(s.q1[j]));
      }
    }
    std::map<GiNaC::ex, double, GiNaC::ex_is_less> sizes;
    auto small_enough = [&](const GiNaC::ex& e) { return tree_size(e, sizes) <= kMaxTreeForGinac; };
    for (int trial = 0; trial < 2; ++trial) {
      const Point x = random_point(model, rng);
      const GiNaC::exmap at = substitution(s, x);
      const Values k = run_full(model.discretizations[d], m, x);
      Values g(m);
      g.Ld = ginac_value(Ld, at);
      for (int i = 0; i < m; ++i) {
        g.D1[i] = ginac_value(D1[i], at);
        g.D2[i] = ginac_value(D2[i], at);
        for (int j = 0; j < m; ++j) {
          g.D11[i * m + j] = small_enough(D11[i * m + j]) ? ginac_value(D11[i * m + j], at) : NAN;
          g.D12[i * m + j] = small_enough(D12[i * m + j]) ? ginac_value(D12[i * m + j], at) : NAN;
          g.D22[i * m + j] = small_enough(D22[i * m + j]) ? ginac_value(D22[i * m + j], at) : NAN;
        }
      }
      expect_close({k.Ld}, {g.Ld}, 1e-10, "Ld");
      expect_close(k.D1, g.D1, 1e-10, "D1");
      expect_close(k.D2, g.D2, 1e-10, "D2");
      // Second derivatives too large for GiNaC's tree evaluation are left out (NaN in g).
      for (std::vector<double>* block : {&g.D11, &g.D12, &g.D22}) {
        for (double& v : *block) {
          if (std::isnan(v)) ++skipped;
          else ++checked;
        }
      }
      auto masked = [](std::vector<double> got, const std::vector<double>& want) {
        for (std::size_t i = 0; i < got.size(); ++i) {
          if (std::isnan(want[i])) got[i] = NAN;
        }
        return got;
      };
      expect_close(masked(k.D11, g.D11), g.D11, 1e-10, "D11");
      expect_close(masked(k.D12, g.D12), g.D12, 1e-10, "D12");
      expect_close(masked(k.D22, g.D22), g.D22, 1e-10, "D22");
    }
  }
  RecordProperty("second_derivatives_checked", static_cast<int>(checked));
  RecordProperty("second_derivatives_left_to_fd", static_cast<int>(skipped));
  if (checked + skipped > 0) EXPECT_GT(checked, 0) << "no second derivative was compared with GiNaC";
}

TEST_P(GeneratedKernels, DerivativesMatchFiniteDifferencesOfTheAction) {
  const pardel_model& model = *entry_.model;
  const int m = model.dim;
  std::mt19937 rng(7u + static_cast<unsigned>(GetParam()));
  for (int d = 0; d < model.ndiscretizations; ++d) {
    const pardel_discretization& disc = model.discretizations[d];
    SCOPED_TRACE(disc.name);
    const Point x = random_point(model, rng);
    const Values k = run_full(disc, m, x);
    std::vector<double> fd1(m), fd2(m), fd11(m * m), fd12(m * m), fd22(m * m);
    for (int j = 0; j < m; ++j) {
      const double eps = 1e-5 * (1.0 + std::fabs(x.q0[j]));
      for (int side = 0; side < 2; ++side) {  // side 0: perturb q0[j], side 1: perturb q1[j]
        Point plus = x, minus = x;
        (side == 0 ? plus.q0 : plus.q1)[j] += eps;
        (side == 0 ? minus.q0 : minus.q1)[j] -= eps;
        const double ap = disc.action(plus.h, plus.t0, plus.t1, plus.q0.data(), plus.q1.data(), plus.p.data());
        const double am = disc.action(minus.h, minus.t0, minus.t1, minus.q0.data(), minus.q1.data(), minus.p.data());
        (side == 0 ? fd1 : fd2)[j] = (ap - am) / (2 * eps);
        const Values vp = run_full(disc, m, plus), vm = run_full(disc, m, minus);
        for (int i = 0; i < m; ++i) {
          if (side == 0) fd11[i * m + j] = (vp.D1[i] - vm.D1[i]) / (2 * eps);
          if (side == 1) fd12[i * m + j] = (vp.D1[i] - vm.D1[i]) / (2 * eps);
          if (side == 1) fd22[i * m + j] = (vp.D2[i] - vm.D2[i]) / (2 * eps);
        }
      }
    }
    expect_close(k.D1, fd1, 1e-6, "D1 vs FD");
    expect_close(k.D2, fd2, 1e-6, "D2 vs FD");
    expect_close(k.D11, fd11, 1e-6, "D11 vs FD");
    expect_close(k.D12, fd12, 1e-6, "D12 vs FD");
    expect_close(k.D22, fd22, 1e-6, "D22 vs FD");
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < m; ++j) {
        EXPECT_EQ(k.D11[i * m + j], k.D11[j * m + i]);
        EXPECT_EQ(k.D22[i * m + j], k.D22[j * m + i]);
      }
    }
  }
}

TEST_P(GeneratedKernels, VariantsAgreeWithTheFullKernel) {
  const pardel_model& model = *entry_.model;
  const int m = model.dim;
  std::mt19937 rng(99u + static_cast<unsigned>(GetParam()));
  for (int d = 0; d < model.ndiscretizations; ++d) {
    const pardel_discretization& disc = model.discretizations[d];
    SCOPED_TRACE(disc.name);
    const Point x = random_point(model, rng);
    const Values full = run_full(disc, m, x);
    Values sweep(m), grad(m);
    disc.sweep(x.h, x.t0, x.t1, x.q0.data(), x.q1.data(), x.p.data(), sweep.D1.data(), sweep.D2.data(),
               sweep.D11.data(), sweep.D22.data());
    disc.grad(x.h, x.t0, x.t1, x.q0.data(), x.q1.data(), x.p.data(), &grad.Ld, grad.D1.data(), grad.D2.data());
    const double action = disc.action(x.h, x.t0, x.t1, x.q0.data(), x.q1.data(), x.p.data());
    expect_close({action}, {full.Ld}, 1e-12, "action");
    expect_close({grad.Ld}, {full.Ld}, 1e-12, "grad Ld");
    expect_close(grad.D1, full.D1, 1e-12, "grad D1");
    expect_close(grad.D2, full.D2, 1e-12, "grad D2");
    expect_close(sweep.D1, full.D1, 1e-12, "sweep D1");
    expect_close(sweep.D2, full.D2, 1e-12, "sweep D2");
    expect_close(sweep.D11, full.D11, 1e-12, "sweep D11");
    expect_close(sweep.D22, full.D22, 1e-12, "sweep D22");
  }
}

// The extended-precision kernels: present as the ABI says (grad_extended for every discretization,
// with interior values condensed in extended precision; full_extended only from order 2), their
// pairs' high parts the double kernels' values, each low part at most half an ulp of its high
// part, and the gradient of full_extended equal to grad_extended's to far below double rounding
// (two CSE'd programs of the same derivatives, or the same condensation).
TEST_P(GeneratedKernels, ExtendedKernelsAgreeWithTheDoubleOnes) {
  const pardel_model& model = *entry_.model;
  const int m = model.dim;
  const std::size_t mm = static_cast<std::size_t>(m) * static_cast<std::size_t>(m);
  std::mt19937 rng(4242u + static_cast<unsigned>(GetParam()));
  for (int d = 0; d < model.ndiscretizations; ++d) {
    const pardel_discretization& disc = model.discretizations[d];
    SCOPED_TRACE(disc.name);
    EXPECT_NE(disc.grad_extended, nullptr);
    EXPECT_EQ(disc.full_extended != nullptr, model.order >= 2);
    if (!disc.grad_extended) continue;
    const Point x = random_point(model, rng);
    const Values full = run_full(disc, m, x);
    std::vector<double> gLd(2), gD1(2 * m), gD2(2 * m);
    disc.grad_extended(x.h, x.t0, x.t1, x.q0.data(), x.q1.data(), x.p.data(), gLd.data(), gD1.data(), gD2.data());
    auto high = [](const std::vector<double>& pairs) {
      std::vector<double> h(pairs.size() / 2);
      for (std::size_t i = 0; i < h.size(); ++i) {
        h[i] = pairs[2 * i];
        EXPECT_LE(std::fabs(pairs[2 * i + 1]), 0.5 * std::fabs(std::nextafter(h[i], INFINITY) - h[i])) << i;
      }
      return h;
    };
    expect_close(high(gLd), {full.Ld}, 1e-12, "grad_extended Ld");
    expect_close(high(gD1), full.D1, 1e-12, "grad_extended D1");
    expect_close(high(gD2), full.D2, 1e-12, "grad_extended D2");
    if (!disc.full_extended) continue;
    std::vector<double> Ld(2), D1(2 * m), D2(2 * m), D11(2 * mm), D12(2 * mm), D22(2 * mm);
    disc.full_extended(x.h, x.t0, x.t1, x.q0.data(), x.q1.data(), x.p.data(), Ld.data(), D1.data(), D2.data(),
                       D11.data(), D12.data(), D22.data());
    expect_close(high(D11), full.D11, 1e-12, "full_extended D11");
    expect_close(high(D12), full.D12, 1e-12, "full_extended D12");
    expect_close(high(D22), full.D22, 1e-12, "full_extended D22");
    // hi + lo against hi + lo: the difference of the pairs, relative to the largest entry.
    auto pair_diff = [](const std::vector<double>& a, const std::vector<double>& b, const char* what) {
      double scale = 0, diff = 0;
      for (std::size_t i = 0; i + 1 < a.size(); i += 2) {
        scale = std::max(scale, std::fabs(b[i]));
        diff = std::max(diff, std::fabs((a[i] - b[i]) + (a[i + 1] - b[i + 1])));
      }
#if defined(PD_HAVE_QUADMATH)
      const double rel = 1e-24;  // __float128: 113 significand bits
#else
      const double rel = 1e-15;  // long double: 64
#endif
      EXPECT_LE(diff, rel * std::max(scale, 1e-300)) << what;
    };
    pair_diff(Ld, gLd, "full_extended Ld vs grad_extended");
    pair_diff(D1, gD1, "full_extended D1 vs grad_extended");
    pair_diff(D2, gD2, "full_extended D2 vs grad_extended");
  }
}

TEST_P(GeneratedKernels, ClockMatchesGinac) {
  const pardel_model& model = *entry_.model;
  if (model.clock == nullptr) GTEST_SKIP() << "the model declares no clock";
  KernelSymbols s(lag_);
  const GiNaC::ex clock = pardel_codegen::interval_clock(lag_, s);
  std::mt19937 rng(5u);
  GiNaC::Digits = 30;
  for (int trial = 0; trial < 3; ++trial) {
    const Point x = random_point(model, rng);
    const double got = model.clock(x.h, x.t0, x.q0.data(), x.q1.data(), x.p.data());
    const double want = ginac_value(clock, substitution(s, x));
    EXPECT_NEAR(got, want, 1e-12 * std::max(1.0, std::fabs(want)));
    EXPECT_GT(got, 0.0);
  }
}

// The travel kernel is the clock under the discretization's own quadrature, the time linear over
// the interval: for the order-1 trapezoid and midpoint rules it is formed here from the left-rule
// clock kernel, h F(t, x0, (x1 - x0)/h), evaluated where each rule evaluates F (the other
// discretizations' orders are measured in tests/python/test_travel_time.py).
TEST_P(GeneratedKernels, TravelIsTheClockUnderTheDiscretizationsQuadrature) {
  const pardel_model& model = *entry_.model;
  for (int k = 0; k < model.ndiscretizations; ++k) {
    const pardel_discretization& d = model.discretizations[k];
    if (model.clock == nullptr) {
      EXPECT_EQ(d.travel, nullptr) << d.name;
      continue;
    }
    ASSERT_NE(d.travel, nullptr) << d.name;
    const std::string name = d.name;
    if (model.order != 1 || (name != "trapezoid" && name != "midpoint")) continue;
    std::mt19937 rng(11u);
    for (int trial = 0; trial < 3; ++trial) {
      const Point x = random_point(model, rng);
      const std::size_t n = x.q0.size();
      std::vector<double> from(n), to(n);
      double want = 0;
      if (name == "trapezoid") {
        for (std::size_t i = 0; i < n; ++i) to[i] = 2 * x.q1[i] - x.q0[i];  // q1 + (q1 - q0)
        want = (model.clock(x.h, x.t0, x.q0.data(), x.q1.data(), x.p.data()) +
                model.clock(x.h, x.t1, x.q1.data(), to.data(), x.p.data())) / 2;
      } else {
        for (std::size_t i = 0; i < n; ++i) {
          from[i] = (x.q0[i] + x.q1[i]) / 2;
          to[i] = from[i] + x.q1[i] - x.q0[i];
        }
        want = model.clock(x.h, (x.t0 + x.t1) / 2, from.data(), to.data(), x.p.data());
      }
      const double got = d.travel(x.h, x.t0, x.t1, x.q0.data(), x.q1.data(), x.p.data());
      EXPECT_NEAR(got, want, 1e-12 * std::max(1.0, std::fabs(want))) << name;
    }
  }
}

std::string model_name(const ::testing::TestParamInfo<int>& info) {
  return kGeneratedModels[info.param].model->name;
}

INSTANTIATE_TEST_SUITE_P(AllModels, GeneratedKernels, ::testing::Range(0, kGeneratedModelCount), model_name);

}  // namespace
