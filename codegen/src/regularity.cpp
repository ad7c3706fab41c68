/**
 * @file regularity.cpp
 * The regularity check of a model (see regularity.hpp): W = ∂²L/∂q^(γ)∂q^(γ) differentiated by
 * GiNaC and evaluated at pseudo-random points in 50-digit arithmetic; its rank (row reduction
 * with a relative tolerance of 1e-30), its null directions, and a bisection for a zero of det W
 * between sample points where det W has opposite signs. Also the discretizations that are not
 * regular for any L, as their rows of the catalogue say (trapezoid(alpha=0)).
 */
#include "pardel_codegen/regularity.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "pardel_codegen/cse.hpp"
#include "pardel_codegen/discretizations.hpp"
#include "pardel_codegen/lag_parser.hpp"

namespace pardel_codegen {
namespace {

using GiNaC::ex;
using GiNaC::numeric;

// Sampling: coordinates and their derivatives uniform in [-2, 2], t in [0, 2], exact binary
// fractions; the params at their defaults for the first points and perturbed for the rest.
constexpr int kDefaultPoints = 24;    // points with every param at its default
constexpr int kPerturbedPoints = 8;   // points with params d (1 + u/4) + v/4, u, v in [-1, 1]
constexpr int kMaxDraws = 400;        // draws per kind before giving up
constexpr int kBisections = 90;
constexpr int kMaxPairs = 20;         // sign-change pairs tried
constexpr long kDigits = 50;

/** Sets GiNaC's working precision for the scope of the check and restores it. */
class DigitsGuard {
 public:
  explicit DigitsGuard(long digits) : saved_(GiNaC::Digits) { GiNaC::Digits = digits; }
  ~DigitsGuard() { GiNaC::Digits = saved_; }
  DigitsGuard(const DigitsGuard&) = delete;
  DigitsGuard& operator=(const DigitsGuard&) = delete;

 private:
  long saved_;
};

/** splitmix64: a small generator whose sequence is the same on every platform. */
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  /** An exact binary fraction uniform in [lo, hi] (24 bits). */
  numeric uniform(int lo, int hi) {
    const numeric u(static_cast<long>(next() >> 40), 1L << 24);
    return numeric(lo) + numeric(hi - lo) * u;
  }

 private:
  std::uint64_t state_;
};

/** A double as the exact rational it stores. */
numeric exact(double d) {
  if (d == 0 || !std::isfinite(d)) return 0;
  int e = 0;
  const double f = std::frexp(d, &e);  // d = f 2^e, 0.5 <= |f| < 1
  const long long m = static_cast<long long>(std::ldexp(f, 53));
  return numeric(static_cast<long>(m)) * numeric(2).power(numeric(e - 53));
}

struct Point {
  std::vector<numeric> values;  // one per varying symbol
  GiNaC::exmap params;          // param symbol -> value
};

struct Evaluated {
  Point point;
  std::vector<numeric> w;  // n x n, row-major
  int rank = 0;
  std::vector<std::vector<double>> null;  // a basis of the null space (reduced row echelon form)
  numeric det;
};

struct Sampler {
  const LagModel& model;
  int n;
  std::vector<GiNaC::symbol> vars;  // t, then every coordinate derivative 0..order
  std::vector<ex> w;                // W, n x n symbolic

  explicit Sampler(const LagModel& m) : model(m), n(m.ncoords()) {
    vars.push_back(m.time);
    for (const auto& level : m.coord_symbols)
      for (const GiNaC::symbol& s : level) vars.push_back(s);
    const auto& top = m.coord_symbols[static_cast<std::size_t>(m.order)];
    w.assign(static_cast<std::size_t>(n * n), 0);
    for (int i = 0; i < n; ++i) {
      const ex di = m.lagrangian.diff(top[static_cast<std::size_t>(i)]);
      for (int j = i; j < n; ++j) {
        const ex dij = di.diff(top[static_cast<std::size_t>(j)]);
        w[static_cast<std::size_t>(i * n + j)] = dij;
        w[static_cast<std::size_t>(j * n + i)] = dij;
      }
    }
  }

  Point draw(Random& rng, bool perturb) const {
    Point p;
    p.values.push_back(rng.uniform(0, 2));
    for (std::size_t k = 1; k < vars.size(); ++k) p.values.push_back(rng.uniform(-2, 2));
    for (const ParamDecl& param : model.params) {
      numeric value = exact(param.default_value);
      if (perturb) {
        const numeric u = rng.uniform(-1, 1), v = rng.uniform(-1, 1);
        value = value * (1 + u / 4) + v / 4;
      }
      p.params[param.symbol] = value;
    }
    return p;
  }

  /** W at `p`; false when an entry is not a finite real number there (outside L's domain). */
  bool evaluate(const Point& p, std::vector<numeric>* out) const {
    GiNaC::exmap m = p.params;
    for (std::size_t k = 0; k < vars.size(); ++k) m[vars[k]] = p.values[k];
    out->assign(w.size(), 0);
    try {
      for (std::size_t k = 0; k < w.size(); ++k) {
        const std::size_t i = k / static_cast<std::size_t>(n), j = k % static_cast<std::size_t>(n);
        if (j < i) {
          (*out)[k] = (*out)[j * static_cast<std::size_t>(n) + i];
          continue;
        }
        const ex v = w[k].subs(m, GiNaC::subs_options::no_pattern).evalf();
        if (!GiNaC::is_a<numeric>(v)) return false;
        const numeric x = GiNaC::ex_to<numeric>(v);
        if (!x.is_real()) return false;
        (*out)[k] = x.real();
      }
    } catch (const std::exception&) {
      return false;  // a pole, log(0), ... at this point
    }
    return true;
  }
};

/** Reduced row echelon form with partial pivoting of S W S, S = diag(|W_ii|^-1/2) (1 where W_ii
 *  is 0), so that the rank does not change with the units of a coordinate; entries below
 *  tol * max |entry| count as 0. The null vectors are W's (S times those of S W S, the free
 *  component 1). */
void reduce(int n, std::vector<numeric> a, int* rank, std::vector<std::vector<double>>* null) {
  std::vector<numeric> sc(static_cast<std::size_t>(n), numeric(1));
  for (int i = 0; i < n; ++i) {
    const numeric d = GiNaC::abs(a[static_cast<std::size_t>(i * n + i)]);
    if (!d.is_zero()) sc[static_cast<std::size_t>(i)] = numeric(1) / GiNaC::sqrt(d);
  }
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      a[static_cast<std::size_t>(i * n + j)] =
          a[static_cast<std::size_t>(i * n + j)] * sc[static_cast<std::size_t>(i)] * sc[static_cast<std::size_t>(j)];
  numeric scale = 0;
  for (const numeric& x : a) scale = std::max(scale, GiNaC::abs(x));
  const numeric tol = scale * numeric(1, 10).power(30);
  std::vector<int> pivot_col;
  int row = 0;
  for (int col = 0; col < n && row < n; ++col) {
    int best = row;
    for (int r = row + 1; r < n; ++r)
      if (GiNaC::abs(a[static_cast<std::size_t>(r * n + col)]) > GiNaC::abs(a[static_cast<std::size_t>(best * n + col)])) best = r;
    if (scale.is_zero() || GiNaC::abs(a[static_cast<std::size_t>(best * n + col)]) <= tol) continue;
    for (int c = 0; c < n; ++c) std::swap(a[static_cast<std::size_t>(row * n + c)], a[static_cast<std::size_t>(best * n + c)]);
    const numeric piv = a[static_cast<std::size_t>(row * n + col)];
    for (int c = 0; c < n; ++c) a[static_cast<std::size_t>(row * n + c)] = a[static_cast<std::size_t>(row * n + c)] / piv;
    for (int r = 0; r < n; ++r) {
      if (r == row) continue;
      const numeric f = a[static_cast<std::size_t>(r * n + col)];
      if (f.is_zero()) continue;
      for (int c = 0; c < n; ++c)
        a[static_cast<std::size_t>(r * n + c)] = a[static_cast<std::size_t>(r * n + c)] - f * a[static_cast<std::size_t>(row * n + c)];
    }
    pivot_col.push_back(col);
    ++row;
  }
  *rank = row;
  null->clear();
  for (int f = 0; f < n; ++f) {
    if (std::find(pivot_col.begin(), pivot_col.end(), f) != pivot_col.end()) continue;
    std::vector<double> v(static_cast<std::size_t>(n), 0.0);
    v[static_cast<std::size_t>(f)] = 1.0;
    for (std::size_t r = 0; r < pivot_col.size(); ++r) {
      const std::size_t c = static_cast<std::size_t>(pivot_col[r]);
      v[c] = (-a[r * static_cast<std::size_t>(n) + static_cast<std::size_t>(f)] * sc[c] / sc[static_cast<std::size_t>(f)])
                 .to_double();
    }
    null->push_back(v);
  }
}

/** det by elimination with partial pivoting (no tolerance). */
numeric determinant(int n, std::vector<numeric> a) {
  numeric det = 1;
  for (int col = 0; col < n; ++col) {
    int best = col;
    for (int r = col + 1; r < n; ++r)
      if (GiNaC::abs(a[static_cast<std::size_t>(r * n + col)]) > GiNaC::abs(a[static_cast<std::size_t>(best * n + col)])) best = r;
    if (a[static_cast<std::size_t>(best * n + col)].is_zero()) return 0;
    if (best != col) {
      for (int c = 0; c < n; ++c) std::swap(a[static_cast<std::size_t>(col * n + c)], a[static_cast<std::size_t>(best * n + c)]);
      det = -det;
    }
    const numeric piv = a[static_cast<std::size_t>(col * n + col)];
    det = det * piv;
    for (int r = col + 1; r < n; ++r) {
      const numeric f = a[static_cast<std::size_t>(r * n + col)] / piv;
      for (int c = col; c < n; ++c)
        a[static_cast<std::size_t>(r * n + c)] = a[static_cast<std::size_t>(r * n + c)] - f * a[static_cast<std::size_t>(col * n + c)];
    }
  }
  return det;
}

std::string primes(int k) { return std::string(static_cast<std::size_t>(k), '\''); }

std::string short_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", std::abs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

/** "(1, -2) in (x'', y'')": the vector v over the highest derivatives, its first nonzero scaled to 1. */
std::string direction(const LagModel& model, const std::vector<double>& v) {
  double first = 0;
  for (double x : v)
    if (std::abs(x) > 1e-12) {
      first = x;
      break;
    }
  std::string values, names;
  for (std::size_t i = 0; i < v.size(); ++i) {
    values += (i ? ", " : "") + short_number(v[i] / first);
    names += (i ? ", " : "") + model.coords[i] + primes(model.order);
  }
  return "(" + values + ") in (" + names + ")";
}

bool same_vector(const std::vector<double>& a, const std::vector<double>& b) {
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::abs(a[i] - b[i]) > 1e-9 * (1 + std::abs(a[i]))) return false;
  return true;
}

/** Sentences naming the null directions of W, from the points where W has the generic rank. */
std::vector<std::string> describe_null(const LagModel& model, const Sampler& s, const std::vector<Evaluated>& at_rank) {
  std::vector<std::string> out;
  const Evaluated& first = at_rank.front();
  const std::string q = "q" + primes(model.order);
  for (std::size_t k = 0; k < first.null.size(); ++k) {
    const std::vector<double>& v = first.null[k];
    bool constant = true;
    for (const Evaluated& e : at_rank)
      if (e.null.size() != first.null.size() || !same_vector(v, e.null[k])) constant = false;
    int nonzero = 0, index = 0;
    for (std::size_t i = 0; i < v.size(); ++i)
      if (std::abs(v[i]) > 1e-12) ++nonzero, index = static_cast<int>(i);
    if (constant && nonzero == 1) {
      const std::string name = model.coords[static_cast<std::size_t>(index)] + primes(model.order);
      if (!model.lagrangian.has(s.model.coord_symbols[static_cast<std::size_t>(model.order)][static_cast<std::size_t>(index)])) {
        out.push_back("L does not depend on " + name);
      } else {
        out.push_back("L is at most linear in " + name + " (d2L/d" + name + "d" + q + " = 0)");
      }
    } else if (constant) {
      out.push_back("W annihilates the direction " + direction(model, v) + ": L has no kinetic term along it");
    } else {
      // A direction that moves with the point: is it that of a lower derivative q^(k) everywhere?
      int along = -1;
      for (int lower = 0; lower < model.order && along < 0 && first.null.size() == 1; ++lower) {
        bool parallel = true;
        for (const Evaluated& e : at_rank) {
          double uv = 0, uu = 0, vv = 0;
          for (int i = 0; i < s.n; ++i) {
            const double u = e.point.values[static_cast<std::size_t>(1 + lower * s.n + i)].to_double();
            const double w = e.null[0][static_cast<std::size_t>(i)];
            uv += u * w, uu += u * u, vv += w * w;
          }
          if (uu == 0 || vv == 0 || std::abs(uv) < (1 - 1e-9) * std::sqrt(uu * vv)) parallel = false;
        }
        if (parallel) along = lower;
      }
      if (along >= 0) {
        const std::string lower = "q" + primes(along);
        out.push_back("W annihilates " + lower + " at every sample point: the component of " + q + " along " +
                      lower + " has no kinetic term");
      } else {
        out.push_back("W annihilates a direction that varies with the point (at the first sample point: " +
                      direction(model, v) + ")");
      }
    }
  }
  return out;
}

/** Whether the symbol's value is printed with a zero of det W. */
std::string point_text(const std::vector<GiNaC::symbol>& vars, const std::vector<bool>& shown, const Point& p) {
  std::string out;
  for (std::size_t k = 0; k < vars.size(); ++k) {
    if (!shown[k]) continue;
    if (!out.empty()) out += ", ";
    out += vars[k].get_name() + " = " + short_number(p.values[k].to_double());
  }
  return out;
}

/** Looks for a zero of det W between default-param points where det W has opposite signs. */
void find_zero(const Sampler& s, const std::vector<Evaluated>& pts, RegularityFindings* f) {
  numeric scale = 0;
  for (const Evaluated& e : pts) scale = std::max(scale, GiNaC::abs(e.det));
  if (scale.is_zero()) return;
  const numeric tiny = scale * numeric(1, 10).power(25);
  int tried = 0;
  for (std::size_t i = 0; i < pts.size() && tried < kMaxPairs; ++i) {
    for (std::size_t j = i + 1; j < pts.size() && tried < kMaxPairs; ++j) {
      const numeric &di = pts[i].det, &dj = pts[j].det;
      if (GiNaC::abs(di) <= tiny || GiNaC::abs(dj) <= tiny || di.csgn() == dj.csgn()) continue;
      ++tried;
      ++f->pairs_bisected;
      // Bisection on the segment from point i to point j (exact rational points).
      numeric lo = 0, hi = 1;
      numeric det_lo = di, det_hi = dj;
      Point mid = pts[i].point;
      bool ok = true;
      std::vector<numeric> w;
      for (int step = 0; step < kBisections && ok; ++step) {
        const numeric m = (lo + hi) / 2;
        for (std::size_t k = 0; k < mid.values.size(); ++k)
          mid.values[k] = pts[i].point.values[k] + m * (pts[j].point.values[k] - pts[i].point.values[k]);
        if (!s.evaluate(mid, &w)) {
          ok = false;
          break;
        }
        const numeric d = determinant(s.n, w);
        if (d.is_zero()) {
          det_lo = det_hi = 0;
          break;
        }
        if (d.csgn() == di.csgn()) lo = m, det_lo = d;
        else hi = m, det_hi = d;
      }
      if (!ok) continue;
      // A zero, not a pole or a jump: det W is small at both ends of the final bracket.
      const numeric bound = std::max(GiNaC::abs(di), GiNaC::abs(dj)) * numeric(1, 10).power(15);
      if (GiNaC::abs(det_lo) > bound || GiNaC::abs(det_hi) > bound) continue;
      std::vector<bool> shown(s.vars.size(), false);
      for (std::size_t k = 0; k < s.vars.size(); ++k) {
        for (const ex& e : s.w) shown[k] = shown[k] || e.has(s.vars[k]);
      }
      if (s.n <= 3) {
        GiNaC::matrix m(static_cast<unsigned>(s.n), static_cast<unsigned>(s.n));
        for (int a = 0; a < s.n; ++a)
          for (int b = 0; b < s.n; ++b) m(static_cast<unsigned>(a), static_cast<unsigned>(b)) = s.w[static_cast<std::size_t>(a * s.n + b)];
        const ex det = m.determinant().expand();
        for (std::size_t k = 0; k < s.vars.size(); ++k) shown[k] = det.has(s.vars[k]);
        std::ostringstream text;
        text << det;
        if (text.str().size() <= 80) f->det_text = text.str();
      }
      f->zero_found = true;
      f->zero_point = point_text(s.vars, shown, mid);
      return;
    }
  }
}

/** `diagnostic` (from lag_diagnostic) with "error" replaced by "warning". */
std::string as_warning(const LagModel& model, int line, int col, const std::string& message) {
  const std::string source = line >= 1 && line <= static_cast<int>(model.source_lines.size())
                                 ? model.source_lines[static_cast<std::size_t>(line - 1)]
                                 : std::string();
  std::string text = lag_diagnostic(model.filename, source, line, col, message);
  const std::string head = model.filename + ":" + std::to_string(line) + ":" + std::to_string(col) + ": error: ";
  return model.filename + ":" + std::to_string(line) + ":" + std::to_string(col) + ": warning: " + text.substr(head.size());
}

/** (line, column) of each name on the `discretizations` line, in order; empty when there is none. */
std::vector<std::pair<int, int>> discretization_positions(const LagModel& model) {
  std::vector<std::pair<int, int>> out;
  const std::string kw = "discretizations";
  for (std::size_t l = 0; l < model.source_lines.size(); ++l) {
    const std::string& s = model.source_lines[l];
    std::size_t i = s.find_first_not_of(" \t");
    if (i == std::string::npos || s.compare(i, kw.size(), kw) != 0) continue;
    i += kw.size();
    if (i < s.size() && s[i] != ' ' && s[i] != '\t' && s[i] != '#') continue;
    auto ident = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; };
    while (i < s.size()) {
      const char c = s[i];
      if (c == '#') break;
      if (c == ' ' || c == '\t' || c == ',') {
        ++i;
      } else if (ident(c)) {
        out.emplace_back(static_cast<int>(l) + 1, static_cast<int>(i) + 1);
        while (i < s.size() && ident(s[i])) ++i;
        std::size_t j = s.find_first_not_of(" \t", i);
        if (j != std::string::npos && s[j] == '(') {
          const std::size_t close = s.find(')', j);
          i = close == std::string::npos ? s.size() : close + 1;
        }
      } else {
        ++i;
      }
    }
    break;
  }
  return out;
}

}  // namespace

RegularityFindings analyze_regularity(const LagModel& model) {
  DigitsGuard digits(kDigits);
  Sampler s(model);
  RegularityFindings f;
  f.ncoords = s.n;
  Random rng(0x70617264656cull);  // fixed: the same points, verdict and messages on every run
  std::vector<Evaluated> at_defaults, all;
  for (int kind = 0; kind < 2; ++kind) {
    const bool perturb = kind == 1;
    if (perturb && model.params.empty()) break;
    const int wanted = perturb ? kPerturbedPoints : kDefaultPoints;
    int got = 0;
    for (int draw = 0; draw < kMaxDraws && got < wanted; ++draw) {
      Evaluated e;
      e.point = s.draw(rng, perturb);
      ++f.tried;
      if (!s.evaluate(e.point, &e.w)) continue;
      ++got;
      reduce(s.n, e.w, &e.rank, &e.null);
      e.det = determinant(s.n, e.w);
      if (!perturb) at_defaults.push_back(e);
      all.push_back(std::move(e));
    }
  }
  f.points = static_cast<int>(all.size());
  f.points_at_defaults = static_cast<int>(at_defaults.size());
  for (const Evaluated& e : all) f.rank = std::max(f.rank, e.rank);
  for (const Evaluated& e : at_defaults) f.rank_at_defaults = std::max(f.rank_at_defaults, e.rank);
  if (all.empty()) return f;
  if (f.rank < s.n) {
    std::vector<Evaluated> at_rank;
    for (const Evaluated& e : all)
      if (e.rank == f.rank) at_rank.push_back(e);
    f.null_directions = describe_null(model, s, at_rank);
    return f;
  }
  if (f.rank_at_defaults == s.n) find_zero(s, at_defaults, &f);
  return f;
}

bool declares_allow_singular(const LagModel& model) {
  for (const std::string& line : model.source_lines) {
    std::size_t i = line.find_first_not_of(" \t");
    if (i == std::string::npos || line[i] != '#') continue;
    i = line.find_first_not_of(" \t", i + 1);
    const std::string tag = "pardel:";
    if (i == std::string::npos || line.compare(i, tag.size(), tag) != 0) continue;
    i = line.find_first_not_of(" \t", i + tag.size());
    const std::string what = "allow-singular";
    if (i == std::string::npos || line.compare(i, what.size(), what) != 0) continue;
    i += what.size();
    if (i == line.size() || line[i] == ' ' || line[i] == '\t') return true;
  }
  return false;
}

std::vector<std::string> check_regularity(const LagModel& model, bool allow_singular) {
  const bool allowed = allow_singular || declares_allow_singular(model);
  std::vector<std::string> warnings;
  const int line = model.lagrangian_line, col = model.lagrangian_column;
  const std::string q = "q" + primes(model.order);
  std::string highest;
  for (std::size_t i = 0; i < model.coords.size(); ++i)
    highest += (i ? ", " : "") + model.coords[i] + primes(model.order);
  const std::string w_name = "W = d2L/d" + q + "d" + q + " (the Hessian of L in " + highest + ")";
  const std::string opt_out =
      "a deliberately degenerate model may say so with a line '# pardel: allow-singular' "
      "(or pardel-gen --allow-singular, pardel_add_model(... ALLOW_SINGULAR))";

  RegularityFindings f;
  try {
    f = analyze_regularity(model);
  } catch (const std::exception& error) {
    // A derivative that cannot be formed, e.g. of a zero base raised to a power that depends on
    // the coordinates ("division by zero").
    if (!symbolic_arithmetic_error(error)) throw;
    const std::string source =
        model.source_lines.empty() ? std::string() : model.source_lines[static_cast<std::size_t>(line - 1)];
    const std::string message = "model '" + model.name + "': L cannot be differentiated symbolically (" +
                                error.what() + "); a zero or negative base raised to a power that depends on " +
                                "the coordinates has no derivative there";
    throw LagError(lag_diagnostic(model.filename, source, line, col, message), line, col, message);
  }
  if (f.points == 0) {
    warnings.push_back(as_warning(model, line, col,
                                  "model '" + model.name + "': regularity not checked: " + w_name +
                                      " is not a finite real number at any of " + std::to_string(f.tried) +
                                      " sample points"));
  } else if (f.rank < f.ncoords) {
    std::string why;
    for (const std::string& d : f.null_directions) why += "; " + d;
    const std::string message = "model '" + model.name + "' is not regular: " + w_name + " has rank " +
                                std::to_string(f.rank) + " of " + std::to_string(f.ncoords) + " at every one of " +
                                std::to_string(f.points) + " sample points" + why;
    const std::string meaning =
        "note: with W singular everywhere the DEL equations are not regular: they do not determine the "
        "motion, and Newton's and Jacobi's iterations need W invertible";
    if (!allowed) {
      const std::string source = model.source_lines.empty() ? std::string()
                                                            : model.source_lines[static_cast<std::size_t>(line - 1)];
      throw LagError(lag_diagnostic(model.filename, source, line, col, message) + "\n" + meaning + "; " + opt_out,
                     line, col, message);
    }
    warnings.push_back(as_warning(model, line, col, message + " (allowed: allow-singular)"));
  } else if (f.points_at_defaults > 0 && f.rank_at_defaults < f.ncoords) {
    warnings.push_back(as_warning(model, line, col,
                                  "model '" + model.name + "': with every param at its default, " + w_name +
                                      " has rank " + std::to_string(f.rank_at_defaults) + " of " +
                                      std::to_string(f.ncoords) +
                                      " at every sample point (other param values make it regular); the DEL "
                                      "equations are not regular at those params"));
  } else if (f.zero_found) {
    warnings.push_back(as_warning(
        model, line, col,
        "model '" + model.name + "': " + w_name + " is singular on part of the domain: det W" +
            (f.det_text.empty() ? std::string() : " = " + f.det_text) +
            " changes sign between sample points and vanishes near " + f.zero_point +
            "; the DEL equations are not regular there, and a solve whose path comes near it may fail"));
  }

  // Discretizations that are not regular for any L (the catalogue's never_regular).
  const std::vector<std::pair<int, int>> where = discretization_positions(model);
  for (std::size_t k = 0; k < model.discretizations.size(); ++k) {
    const DiscretizationSpec& spec = model.discretizations[k];
    const char* reason = spec.family && spec.family->never_regular ? spec.family->never_regular(spec) : nullptr;
    if (reason == nullptr) continue;
    const int dl = k < where.size() ? where[k].first : line, dc = k < where.size() ? where[k].second : col;
    const std::string message =
        "model '" + model.name + "': discretization '" + spec.name + "' is not regular: " + reason;
    if (!allowed) {
      const std::string source = model.source_lines[static_cast<std::size_t>(dl - 1)];
      throw LagError(lag_diagnostic(model.filename, source, dl, dc, message) + "\nnote: " + opt_out, dl, dc, message);
    }
    warnings.push_back(as_warning(model, dl, dc, message + " (allowed: allow-singular)"));
  }
  return warnings;
}

}  // namespace pardel_codegen
