/**
 * @file error_estimate.cpp
 * Richardson's estimate of the discretization error at the nodes and the extrapolated node values
 * (error_estimate.hpp): which coarse grid a solve can be compared with, the comparison, and its
 * check by the order observed over a third grid level.
 */
#include "error_estimate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "engine.hpp"
#include "invariant.hpp"
#include "levels.hpp"

namespace pardel::detail {
namespace {

/** The round-off level of values up to `size` in magnitude, below which two solutions differ by
 *  rounding alone: 8 eps size. */
double rounding_level(double size) { return 8 * std::numeric_limits<double>::epsilon() * size; }

std::string number(double v, int digits = 10) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", digits, v);
  return buf;
}

/** The index of the knot that lies on an odd node of the grid with N intervals, or -1. */
int knot_on_odd_node(const Problem& problem) {
  for (std::size_t a = 0; a < problem.knots.size(); ++a)
    if (knot_node(problem, a, problem.N, nullptr) % 2 != 0) return static_cast<int>(a);
  return -1;
}

/** Lagrange weights at x of the nodes a, a+1, ..., a+n-1 (n <= 4). */
void lagrange_weights(double x, int a, int n, double* w) {
  for (int i = 0; i < n; ++i) {
    double num = 1, den = 1;
    for (int j = 0; j < n; ++j) {
      if (j == i) continue;
      num *= x - (a + j);
      den *= static_cast<double>(i - j);
    }
    w[i] = num / den;
  }
}

/** The p at which an error C h^p makes the observed differences d1 = |x_N - x_N/r1| and
 *  d2 = |x_N/r1 - x_N/(r1 r2)|: d2 / d1 = r1^p (r2^p - 1) / (r1^p - 1), which grows with p
 *  (r1^p where r1 = r2). */
double observed_order(double d1, double d2, int r1, int r2) {
  if (r1 == r2) return std::log(d2 / d1) / std::log(r1);
  auto quotient = [&](double p) { return std::pow(r1, p) * (std::pow(r2, p) - 1) / (std::pow(r1, p) - 1); };
  const double target = d2 / d1;
  double lo = 1e-6, hi = 64;
  if (!(target > quotient(lo))) return std::log(target) / std::log(r1 * r2);  // below: at most ~0
  if (target >= quotient(hi)) return hi;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (quotient(mid) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

/** The least observed order q for which the estimate with the nominal p stays within a factor 3
 *  of an error that falls with order q: r^q - 1 = (r^p - 1) / 3 (1 for p = 2, 6.43 for p = 8 at r = 2). */
double least_order(int p, int r) { return std::log1p((std::pow(r, p) - 1) / 3) / std::log(r); }
/** The greatest such q: r^q - 1 = 3 (r^p - 1) (3.32 for p = 2, 5.52 for p = 4, 9.58 for p = 8 at
 *  r = 2). Above it the differences fall faster than any error of the nominal order: the grids are
 *  not yet in the range where the error is C h^p (a forcing or a layer that the coarser grids do
 *  not resolve), and the finer two may share an error that their difference does not show. */
double greatest_order(int p, int r) { return std::log1p(3 * (std::pow(r, p) - 1)) / std::log(r); }

/** The order the estimate uses, the one the extrapolation uses, what the check of the observed
 *  order found, and its note. */
struct Order {
  double p = 0;
  double extrapolation_p = 0;
  double observed = std::numeric_limits<double>::quiet_NaN();
  bool reliable = false;
  bool at_round_off = false;  ///< the three levels agree to within 100 times round-off
  std::string note;
};

/** The note's words on an agreement to round-off that nested grids cannot confirm (check_order,
 *  confirm_round_off). */
const std::string kUnconfirmedAgreement =
    " (not confirmed: L depends on t, and a jump or kink in t that all three grids' quadrature points miss alike "
    "near a node they share gives the same agreement; another grid of other nodes does confirm it)";


/** Where the grid `level` has a single interval between two fixed times (the ends and the knots),
 *  that stretch ("between t = 0.2 and the knot at t = 1.13"); empty where every stretch has two
 *  or more. Not checked under a clock (no knots there). */
std::string lone_interval(const Problem& problem, const Trajectory& level) {
  if (problem.knots.empty() || problem.clock != ClockMode::none) return {};
  std::vector<double> fixed{problem.t0, problem.t0 + problem.T};
  for (const Knot& knot : problem.knots) fixed.push_back(knot.t);
  std::sort(fixed.begin(), fixed.end());
  const double tolerance = time_tolerance(problem);
  for (std::size_t a = 0; a + 1 < fixed.size(); ++a) {
    int inside = 0;  // nodes strictly between the two fixed times
    for (int m = 0; m <= level.N; ++m) {
      const double t = level_time(problem, level, m);
      if (t > fixed[a] + tolerance && t < fixed[a + 1] - tolerance) ++inside;
    }
    if (inside == 0)
      return "between t = " + number(fixed[a], 6) + " and t = " + number(fixed[a + 1], 6) + " (a knot at one end)";
  }
  return {};
}

/** The check of the nominal order against `third` (docs/solvers.md, "Error estimate"): the largest
 *  differences over the coordinates at the third level's nodes, which all three grids share. */
Order check_order(const Problem& problem, const Trajectory& fine, const Trajectory& coarse, int ratio,
                  const ThirdLevel& third, const std::vector<double>& roundoff) {
  const int p = problem.discretization->consistency_order;
  Order out;
  out.p = p;
  out.extrapolation_p = p;
  if (!third.level) {
    out.note = "; not checked by a third grid level (" + third.why_not + ")";
    return out;
  }
  const Trajectory& c2 = *third.level;
  PARDEL_INVARIANT(coarse.N == c2.N * third.ratio, "the third level is nested in the coarse one");
  const std::string lone = lone_interval(problem, c2);
  if (!lone.empty()) {
    out.note = "; not checked by the third grid level N = " + std::to_string(c2.N) + ": it has a single interval " +
               lone + ", too coarse for the error there to fall with any order";
    return out;
  }
  // Each coordinate's differences on its own: one that shows its order cannot vouch for another
  // whose grids are not yet where its error falls (a slow and a fast oscillator side by side), nor
  // a large coordinate's round-off hide another's differences.
  const int nc = problem.model->ncoords;
  std::vector<double> d1(static_cast<std::size_t>(nc), 0.0), d2(static_cast<std::size_t>(nc), 0.0);
  for (int m = 0; m <= c2.N; ++m)
    for (std::size_t i = 0; i < static_cast<std::size_t>(nc); ++i) {
      const double a = c2.node(m)[i], b = coarse.node(m * third.ratio)[i], f = fine.node(m * third.ratio * ratio)[i];
      d1[i] = std::max(d1[i], std::fabs(f - b));
      d2[i] = std::max(d2[i], std::fabs(b - a));
    }
  const std::string grids = "N = " + std::to_string(fine.N) + ", " + std::to_string(coarse.N) + " and " +
                            std::to_string(c2.N);
  // Within 100 times its round-off a coordinate's solutions agree and show no order.
  std::vector<std::size_t> showing;  // the coordinates that show one
  for (std::size_t i = 0; i < static_cast<std::size_t>(nc); ++i)
    if (d1[i] > 100 * roundoff[i] || (d2[i] > 100 * roundoff[i] && problem.model->time_dependent))
      showing.push_back(i);
  if (showing.empty()) {
    // The solutions agree: the discretization is exact for this motion, or (where L or the clock
    // depends on t) a jump or kink of the data in t that every grid's quadrature points miss alike,
    // near a node the grids share, gives the same agreement. There all three levels must agree,
    // and that is confirmed only by another grid (solve_adaptive: a second grid of other nodes on
    // which it holds too).
    out.at_round_off = true;
    out.reliable = !problem.model->time_dependent;
    out.note = "; on " + grids + " the " + (problem.model->time_dependent ? "three" : "two finer") +
               " solutions agree to within 100 times round-off, where no order is observed";
    if (!out.reliable) out.note += kUnconfirmedAgreement;
    return out;
  }
  double D1 = 0, D2 = 0;  // the largest differences of the coordinates that show an order
  for (const std::size_t i : showing) {
    D1 = std::max(D1, d1[i]);
    D2 = std::max(D2, d2[i]);
  }
  out.observed = observed_order(D1, D2, ratio, third.ratio);
  const std::string observed = "observed order " + number(out.observed, 3) + " on " + grids;
  if (out.observed > greatest_order(p, ratio)) {
    out.note = "; estimate unreliable: " + observed + ", above the " + std::to_string(p) +
               " expected: the grids are not yet where the error falls with that order (a feature the coarser " +
               "grids do not resolve), so the error may be far from the estimate (which uses order " +
               std::to_string(p) + ")";
    return out;
  }
  if (out.observed >= least_order(p, ratio)) {
    // Confirmed where every coordinate that shows an order confirms it too. Below p the estimate
    // takes the least observed order, which makes it larger (the error may not yet fall with p);
    // the extrapolation keeps p, whose leading term it removes.
    double least = out.observed;
    for (const std::size_t i : showing) {
      const double q = observed_order(d1[i], d2[i], ratio, third.ratio);
      const std::string name = problem.model->coords ? problem.model->coords[i] : std::to_string(i);
      if (q > greatest_order(p, ratio) || q < least_order(p, ratio)) {
        out.note = "; estimate unreliable: " + observed + ", but coordinate " + name + "'s differences show order " +
                   number(q, 3) + " where " + std::to_string(p) +
                   " is expected: its grids are not yet where its error falls with that order, so its error may be "
                   "far from the estimate";
        return out;
      }
      least = std::min(least, q);
    }
    out.reliable = true;
    out.note = "; " + observed + " (" + std::to_string(p) + " expected";
    if (least < p) {
      out.p = least;
      out.note += least < out.observed ? ", and the estimate uses the least order a coordinate shows, " + number(least, 3)
                                       : ", and the estimate uses the observed order";
    }
    out.note += ")";
    return out;
  }
  out.p = std::clamp(out.observed, 1.0, static_cast<double>(p));
  out.extrapolation_p = out.p;
  out.note = "; estimate unreliable: " + observed + " where " + std::to_string(p) +
             " is expected, so the estimate uses order " + number(out.p, 3);
  return out;
}

/** The nodes of `level` that hold a knot (sorted): the correction's slope jumps there, so that
 *  add_corrections interpolates within each stretch between them. None under a clock. */
std::vector<int> knot_nodes(const Problem& problem, const Trajectory& level) {
  std::vector<int> nodes;
  if (problem.knots.empty() || problem.clock != ClockMode::none) return nodes;
  const double tolerance = time_tolerance(problem);
  for (const Knot& knot : problem.knots)
    for (int m = 1; m < level.N; ++m)
      if (std::fabs(level_time(problem, level, m) - knot.t) <= tolerance) nodes.push_back(m);
  std::sort(nodes.begin(), nodes.end());
  return nodes;
}

/** fine + e: at a common node its own e, elsewhere the cubic (fewer nodes on tiny stretches)
 *  through the four nearest common nodes of its stretch between the ends and the knot nodes
 *  `breaks` (common-node indices), in the node index; the node times too under a clock. */
void add_corrections(const std::vector<double>& e, const std::vector<double>& et, int ratio, bool clocked,
                     const std::vector<int>& breaks, Trajectory& fine) {
  const int d = fine.dim, Nc = fine.N / ratio;
  double w[4];
  for (int k = 0; k <= fine.N; ++k) {
    double* f = fine.node(k);
    if (k % ratio == 0) {
      const double* em = e.data() + static_cast<std::size_t>(k / ratio) * d;
      for (int i = 0; i < d; ++i) f[i] += em[i];
      if (clocked) fine.t[static_cast<std::size_t>(k)] += et[static_cast<std::size_t>(k / ratio)];
      continue;
    }
    const double x = static_cast<double>(k) / ratio;
    const int below = static_cast<int>(std::floor(x));
    int lo = 0, hi = Nc;  // the stretch of common nodes that holds x
    for (const int b : breaks) {
      if (b <= below) lo = std::max(lo, b);
      if (b > below) hi = std::min(hi, b);
    }
    const int n = std::min(4, hi - lo + 1);
    const int a = std::clamp(below - (n - 1) / 2, lo, hi + 1 - n);
    lagrange_weights(x, a, n, w);
    for (int j = 0; j < n; ++j) {
      const double* em = e.data() + static_cast<std::size_t>(a + j) * d;
      for (int i = 0; i < d; ++i) f[i] += w[j] * em[i];
      if (clocked) fine.t[static_cast<std::size_t>(k)] += w[j] * et[static_cast<std::size_t>(a + j)];
    }
  }
}

}  // namespace

std::string coarse_grid_refusal(const Problem& problem) {
  if (problem.N < 4) return "N = " + std::to_string(problem.N) + " is below 4";
  if (problem.N % 2 != 0)
    return "N = " + std::to_string(problem.N) + " is odd, and the coarse grid of every other node needs an even N";
  const int knot = knot_on_odd_node(problem);
  if (knot >= 0)
    return "knot " + std::to_string(knot) + " (t = " + number(problem.knots[static_cast<std::size_t>(knot)].t) +
           ") is on an odd node, which the coarse grid of every other node does not have";
  PARDEL_INVARIANT(!problem.times.empty() || knots_on_grid(problem, problem.N / 2),
                   "knots on even nodes lie on the coarse grid");
  return "";
}

Trajectory every_other_node(const Trajectory& fine, int ratio) {
  PARDEL_INVARIANT(ratio >= 1 && fine.N % ratio == 0, "the coarse grid is every ratio-th node of the fine one");
  Trajectory coarse;
  coarse.N = fine.N / ratio;
  coarse.dim = fine.dim;
  const std::size_t d = static_cast<std::size_t>(fine.dim);
  coarse.q.resize((static_cast<std::size_t>(coarse.N) + 1) * d);
  if (!fine.t.empty()) coarse.t.resize(static_cast<std::size_t>(coarse.N) + 1);
  for (int m = 0; m <= coarse.N; ++m) {
    std::copy(fine.node(m * ratio), fine.node(m * ratio) + d, coarse.node(m));
    if (!fine.t.empty()) coarse.t[static_cast<std::size_t>(m)] = fine.t[static_cast<std::size_t>(m) * ratio];
  }
  return coarse;
}

bool nested_level(const Problem& problem, const Trajectory& fine, const Trajectory& coarse, int* ratio) {
  if (coarse.N < 2 || fine.N <= coarse.N || fine.N % coarse.N != 0 || coarse.dim != fine.dim) return false;
  const std::size_t nodes = static_cast<std::size_t>(coarse.N) + 1;
  if (coarse.q.size() != nodes * static_cast<std::size_t>(coarse.dim) || coarse.t.size() != nodes ||
      fine.t.size() != static_cast<std::size_t>(fine.N) + 1)
    return false;
  const int r = fine.N / coarse.N;
  if (problem.clock == ClockMode::none) {
    // Uniform grids: the same times at the common nodes (to rounding).
    const double eps = 1e-12 * (std::fabs(problem.t0) + problem.T);
    for (std::size_t m = 0; m < nodes; ++m)
      if (std::fabs(coarse.t[m] - fine.t[m * static_cast<std::size_t>(r)]) > eps) return false;
  }
  *ratio = r;
  return true;
}

void record_solve_error(const std::vector<double>& delta, int dim, int ncoords, Summary& summary) {
  const std::size_t dz = static_cast<std::size_t>(dim), nc = static_cast<std::size_t>(std::min(ncoords, dim));
  std::vector<double> by(nc, 0.0);
  bool finite = true;
  for (std::size_t i = 0; i < delta.size(); ++i) {
    const std::size_t a = i % dz;
    if (a >= nc) continue;
    if (!std::isfinite(delta[i])) finite = false;
    by[a] = std::max(by[a], std::fabs(delta[i]));
  }
  if (!finite) return;
  summary.solve_error = nc > 0 ? *std::max_element(by.begin(), by.end()) : 0.0;
  summary.solve_error_by_coordinate = std::move(by);
}

void include_solve_error(Summary& summary) {
  if (std::isfinite(summary.error_time_estimate) && std::isfinite(summary.solve_time_error)) {
    summary.error_time_estimate += summary.solve_time_error;
    summary.error_note += "; the node times' estimate with the solve's own error in them, " +
                          number(summary.solve_time_error, 3) + ", added";
  }
  if (!std::isfinite(summary.error_estimate) || !std::isfinite(summary.solve_error)) return;
  std::vector<double>& by = summary.error_by_coordinate;
  if (by.size() == summary.solve_error_by_coordinate.size() && !by.empty()) {
    for (std::size_t i = 0; i < by.size(); ++i) by[i] += summary.solve_error_by_coordinate[i];
    summary.error_estimate = *std::max_element(by.begin(), by.end());
  } else {
    summary.error_estimate += summary.solve_error;
  }
  summary.error_note += "; with the solve's own error " + number(summary.solve_error, 3) +
                        " (the Newton correction at the answer) added";
}

void confirm_round_off(Summary& summary, int other_N) {
  PARDEL_INVARIANT(summary.error_at_round_off, "an agreement to round-off is what another grid confirms");
  summary.error_reliable = true;
  const std::size_t at = summary.error_note.find(kUnconfirmedAgreement);
  if (at != std::string::npos) summary.error_note.erase(at, kUnconfirmedAgreement.size());
  summary.error_note += "; confirmed by the solve on N = " + std::to_string(other_N) +
                        " before it, whose nodes shared by its three levels lie midway between this grid's, and whose levels agree "
                        "to round-off too";
}

double level_time(const Problem& problem, const Trajectory& level, int m) {
  const bool own = level.t.size() == static_cast<std::size_t>(level.N) + 1;
  return own ? level.t[static_cast<std::size_t>(m)] : problem.t0 + problem.T * m / level.N;
}

double time_tolerance(const Problem& problem) { return 1e-9 * std::max(1.0, std::fabs(problem.T)); }

void not_estimated(Summary& summary, const std::string& why) {
  summary.error_estimate = std::numeric_limits<double>::quiet_NaN();
  summary.error_by_coordinate.clear();
  summary.error_coarse_N = 0;
  summary.error_time_estimate = std::numeric_limits<double>::quiet_NaN();
  summary.extrapolated = false;
  summary.error_observed_order = std::numeric_limits<double>::quiet_NaN();
  summary.error_reliable = false;
  summary.error_at_round_off = false;
  summary.error_note = "not estimated: " + why;
}

void richardson(const Problem& problem, const Trajectory& coarse, int ratio, const ThirdLevel& third, bool extrapolate,
                Trajectory& fine, Summary& summary) {
  PARDEL_INVARIANT(fine.N == coarse.N * ratio && fine.dim == coarse.dim, "the coarse grid is nested in the fine one");
  const int nc = problem.model->ncoords, d = fine.dim, Nc = coarse.N;
  const bool clocked = problem.clock != ClockMode::none && fine.t.size() == static_cast<std::size_t>(fine.N) + 1 &&
                       coarse.t.size() == static_cast<std::size_t>(Nc) + 1;
  // Below the round-off of a coordinate's values two solutions differ by rounding alone.
  std::vector<double> roundoff(static_cast<std::size_t>(nc), 0.0);
  for (int i = 0; i < nc; ++i) {
    double size = 0;
    for (int k = 0; k <= fine.N; ++k) size = std::max(size, std::fabs(fine.node(k)[i]));
    roundoff[static_cast<std::size_t>(i)] = rounding_level(size);
  }
  const Order order = check_order(problem, fine, coarse, ratio, third, roundoff);
  const double factor = std::pow(static_cast<double>(ratio), order.p) - 1;
  const double extrapolation_factor = std::pow(static_cast<double>(ratio), order.extrapolation_p) - 1;
  // e at the common nodes, every component; the node times' under a clock.
  std::vector<double> e((static_cast<std::size_t>(Nc) + 1) * static_cast<std::size_t>(d));
  std::vector<double> et(clocked ? static_cast<std::size_t>(Nc) + 1 : 0, 0.0);
  std::vector<double> by_coordinate(static_cast<std::size_t>(nc), 0.0);
  for (int m = 0; m <= Nc; ++m) {
    const double* f = fine.node(m * ratio);
    const double* c = coarse.node(m);
    double* em = e.data() + static_cast<std::size_t>(m) * d;
    for (int i = 0; i < d; ++i) {
      em[i] = (f[i] - c[i]) / extrapolation_factor;
      if (i < nc)
        by_coordinate[static_cast<std::size_t>(i)] =
            std::max(by_coordinate[static_cast<std::size_t>(i)], std::fabs(f[i] - c[i]) / factor);
    }
    if (clocked)
      et[static_cast<std::size_t>(m)] =
          (fine.t[static_cast<std::size_t>(m) * ratio] - coarse.t[static_cast<std::size_t>(m)]) / extrapolation_factor;
  }
  // Such a difference does not resolve the error, which is reported as the round-off level instead (not less).
  bool at_roundoff = false;
  for (std::size_t i = 0; i < by_coordinate.size(); ++i)
    if (by_coordinate[i] < roundoff[i]) {
      by_coordinate[i] = roundoff[i];
      at_roundoff = true;
    }
  summary.error_estimate = *std::max_element(by_coordinate.begin(), by_coordinate.end());
  summary.error_by_coordinate = std::move(by_coordinate);
  summary.error_coarse_N = Nc;
  summary.extrapolated = false;
  summary.error_observed_order = order.observed;
  summary.error_reliable = order.reliable;
  summary.error_at_round_off = order.at_round_off;
  const std::string every = ratio == 2 ? "other" : std::to_string(ratio) + "th";
  summary.error_note = "max over the " + std::to_string(Nc + 1) + " common nodes and the coordinates of |x_" +
                       std::to_string(fine.N) + " - x_" + std::to_string(Nc) + "| / (" + std::to_string(ratio) + "^" +
                       number(order.p, 3) + " - 1), the solution on N = " + std::to_string(fine.N) +
                       " against that on every " + every + " node";
  if (at_roundoff)
    summary.error_note += "; below the round-off level of a coordinate (8 eps max|x|) the difference is rounding "
                          "alone, and that level is reported instead";
  summary.error_note += order.note;
  summary.error_time_estimate = std::numeric_limits<double>::quiet_NaN();
  if (problem.clock == ClockMode::free_final_time && clocked && problem.discretization &&
      problem.discretization->travel) {
    double time_error = 0, largest = 0;
    for (int m = 0; m <= Nc; ++m)
      time_error = std::max(time_error, std::fabs(fine.t[static_cast<std::size_t>(m) * ratio] -
                                                  coarse.t[static_cast<std::size_t>(m)]));
    for (double t : fine.t) largest = std::max(largest, std::fabs(t));
    // Below the times' round-off the difference is rounding alone, as for the coordinates.
    summary.error_time_estimate = std::max(time_error / factor, rounding_level(largest));
    summary.error_note += "; the node times (the clock integrated over each interval by the discretization's "
                          "quadrature), estimated alike: " + number(summary.error_time_estimate, 3);
  } else if (problem.clock == ClockMode::free_final_time) {
    summary.error_note += "; the node times and the final time (the clock summed by the left rule, the "
                          "discretization having no travel kernel: first order in the step) are not in this estimate";
  }
  if (!extrapolate) return;
  if (!order.reliable) {
    // An estimate that the check did not confirm says too little of the error to correct the path by.
    summary.error_note += "; not extrapolated: the estimate is not confirmed";
    return;
  }
  add_corrections(e, et, ratio, clocked, knot_nodes(problem, coarse), fine);
  summary.extrapolated = true;
}

}  // namespace pardel::detail
