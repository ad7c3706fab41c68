/**
 * @file assessment.cpp
 * What a returned trajectory is as a stationary point of the discrete action: the inertia of the
 * Hessian from its block LDL^T (minimum, saddle of index k, degenerate) and, at a minimum, its two
 * smallest eigenvalues by Lanczos on the inverse (the second one with the first deflated), and
 * where those two are nearly equal the third (with both deflated), against Gershgorin's bound on
 * the largest, which tells a well-posed minimum from a nearly degenerate one.
 * O(N) work: one factorization (or Newton's last one, at the same point) and at most 2 x 24 solves
 * where lambda_1's run takes at most 4 steps, 3 x 24 otherwise, and up to 2 x 24 more for the
 * third (a replay of the second run and the third run); from a coarser level's eigenvectors
 * (LevelEigenvectors, Newton's nested levels) one solve per run on smooth problems. Also the check
 * that refuses a degenerate Lagrangian before solving.
 */
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "assessment.hpp"
#include "block_tridiagonal.hpp"
#include "extended_assessment.hpp"
#include "constants.hpp"
#include "iterative_refinement.hpp"
#include "lanczos.hpp"

namespace pardel::detail {
namespace {

/** Whether the two smallest eigenvalues lie within a factor 2 of each other (as a repeated lowest
 *  mode makes them), where their ratio cannot show a nearly degenerate minimum and the third is
 *  computed and compared instead. */
bool lowest_two_close(double lambda_min, double lambda_next) {
  return lambda_next > 0 && lambda_next < 2 * lambda_min;
}

std::string format(const char* fmt, double a, double b = 0, double c = 0, double d = 0, double e = 0) {
  char buf[512];
  std::snprintf(buf, sizeof buf, fmt, a, b, c, d, e);
  return buf;
}


/** Scales the rows, then the columns, of a d x d row-major block by their largest |entry| (a zero
 *  row or column is left as it is): a congruence of diagonal matrices, which keeps the rank. */
void equilibrate(double* block, int d) {
  const std::size_t dz = static_cast<std::size_t>(d);
  for (std::size_t i = 0; i < dz; ++i) {
    double m = 0;
    for (std::size_t j = 0; j < dz; ++j) m = std::max(m, std::fabs(block[i * dz + j]));
    if (m > 0)
      for (std::size_t j = 0; j < dz; ++j) block[i * dz + j] /= m;
  }
  for (std::size_t j = 0; j < dz; ++j) {
    double m = 0;
    for (std::size_t i = 0; i < dz; ++i) m = std::max(m, std::fabs(block[i * dz + j]));
    if (m > 0)
      for (std::size_t i = 0; i < dz; ++i) block[i * dz + j] /= m;
  }
}

/** The smallest singular value of a d x d row-major block against its largest. */
double relative_smallest_singular_value(const double* block, int d) {
  Eigen::MatrixXd A = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(block, d, d);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A);
  const auto& s = svd.singularValues();
  if (!(s(0) > 0)) return 0;
  return s(d - 1) / s(0);
}

/** Sum over the rank's free components of a[i] b[i], reduced over the ranks. */
double dot(const LanczosOperator& op, const double* a, const double* b) {
  double s = 0;
  for (std::size_t i = 0; i < op.n; ++i) s += op.free[i] ? a[i] * b[i] : 0.0;
  op.reduce(&s, 1);
  return s;
}

/** The largest eigenvalue of the tridiagonal T (diagonal alpha, off-diagonal beta), its unit
 *  eigenvector and the next eigenvalue (-infinity for T of order 1). */
double top_ritz(const std::vector<double>& alpha, const std::vector<double>& beta, Eigen::VectorXd* vector,
                double* second) {
  const Eigen::Index k = static_cast<Eigen::Index>(alpha.size());
  Eigen::VectorXd d = Eigen::Map<const Eigen::VectorXd>(alpha.data(), k);
  Eigen::VectorXd e = Eigen::Map<const Eigen::VectorXd>(beta.data(), k - 1);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig;
  eig.computeFromTridiagonal(d, e, Eigen::ComputeEigenvectors);
  if (eig.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  *vector = eig.eigenvectors().col(k - 1);
  *second = k > 1 ? eig.eigenvalues()(k - 2) : -std::numeric_limits<double>::infinity();
  return eig.eigenvalues()(k - 1);
}

/** Where the vectors v_0, v_1, ... of a Lanczos run live: v_j in slot[j % cycle] (cycle 3 or 4). */
struct Basis {
  double* const* slot = nullptr;
  int cycle = 3;
  double* at(int j) const { return slot[j % cycle]; }
};

/** Projects v off the K orthonormal vectors y[0 .. K-1] over the free components (zero on the
 *  fixed ones) and scales it to unit length: the dot products with y and v.v in one pass, then the
 *  projection and the scaling in one, |P v|^2 = v.v - sum (v.y_m)^2; where that difference cancels
 *  (below 1e-4 of v.v), P v is formed first and its norm taken. Returns |P v|, or 0 where that is
 *  zero or not finite (v then not scaled). */
template <int K>
double deflate(const LanczosOperator& op, double* v, const double* const* y) {
  const std::size_t n = op.n;
  const unsigned char* free = op.free;
  std::array<double, K + 1> sums{};  // v.y_m, then v.v
  for (std::size_t i = 0; i < n; ++i) {
    if (!free[i]) continue;
    for (int m = 0; m < K; ++m) sums[m] += v[i] * y[m][i];
    sums[K] += v[i] * v[i];
  }
  op.reduce(sums.data(), K + 1);
  std::array<double, K + 1> c{};
  double norm2 = sums[K];
  for (int m = 0; m < K; ++m) {
    c[m] = sums[m];
    norm2 -= c[m] * c[m];
  }
  if (K > 0 && !(norm2 > 1e-4 * sums[K])) {
    for (std::size_t i = 0; i < n; ++i)
      for (int m = 0; m < K; ++m) v[i] -= c[m] * y[m][i];
    norm2 = dot(op, v, v);
    c.fill(0);
  }
  const double norm = std::sqrt(norm2);
  if (!(norm > 0) || !std::isfinite(norm)) return 0;
  for (std::size_t i = 0; i < n; ++i) {
    double vi = v[i];
    for (int m = 0; m < K; ++m) vi -= c[m] * y[m][i];
    v[i] = free[i] ? vi / norm : 0.0;
  }
  return norm;
}

/**
 * Lanczos on A = H^-1 over the free components, projected against the K orthonormal vectors
 * y[0 .. K-1] (A restricted to their complement; K = 0: A itself), from the start vector in
 * basis.at(0) (any norm): the
 * largest eigenvalue mu of A there, by the largest Ritz value of T_j, and 1/mu, an upper bound on
 * the smallest eigenvalue of H there. Stops when the residual bound puts mu within `settle`
 * (relative) of an eigenvalue (after 3 steps at least), when the Krylov space is invariant, or at
 * the budget of kLanczosSteps; then basis.at(steps) holds the residual W = A v_k - alpha_k v_k -
 * beta_{k-1} v_{k-1} of the last step, not normalized, so that A V = V T + W e_k^T (V the basis,
 * T the tridiagonal of alpha and beta) and A x = mu x + s_k W for the Ritz vector x = V s.
 * With `replay` (an earlier run from the same start) it recomputes the same vectors and that W,
 * and accumulates x = sum_j s_j v_j into x. With `warm` (a start vector that is nearly an
 * eigenvector: a coarser level's, LevelEigenvectors) it also settles at any step where the
 * residual alone puts mu within `settle` (Weinstein's bound: an eigenvalue lies within r of the
 * Ritz value), which the first step of such a start does.
 */
struct Lanczos {
  std::vector<double> alpha, beta;
  Eigen::VectorXd s;  ///< the top Ritz vector of T
  double lambda = 0;  ///< 1 / (largest Ritz value)
  bool settled = false;
  bool complete = false;  ///< ended settled or at the budget, with W in basis.at(steps)
  double start_norm = 0;  ///< the norm of the start vector (after the projection off y)
  int steps() const { return static_cast<int>(alpha.size()); }
};
template <int K>
Lanczos lanczos(const LanczosOperator& op, const Basis& basis, const double* const* y, double settle, bool warm,
                const Lanczos* replay = nullptr, double* x = nullptr) {
  const std::size_t n = op.n;
  const unsigned char* free = op.free;
  Lanczos run;
  double* v0 = basis.at(0);
  const double norm = deflate<K>(op, v0, y);
  if (!(norm > 0)) return run;
  run.start_norm = norm;
  if (x) std::fill(x, x + n, 0.0);
  const int steps = replay ? replay->steps() : kLanczosSteps;
  for (int j = 0; j < steps; ++j) {
    double* cur = basis.at(j);
    double* next = basis.at(j + 1);
    const double b_prev = j > 0 ? (replay ? replay->beta[j - 1] : run.beta[j - 1]) : 0.0;
    const double* prev = j > 0 ? basis.at(j - 1) : cur;  // times b_prev = 0 at j = 0
    op.solve(cur, next);
    // W = P A v_j - beta_{j-1} v_{j-1} - alpha_j v_j (P the projection off the y_m; fixed
    // components zero), in two passes over the vectors: without y, those of lanczos_recurrence;
    // with y, the first only forms the dot products that give c_m = y_m.A v_j and alpha_j =
    // v_j.(A v_j - sum c_m y_m - beta_{j-1} v_{j-1}) (expanded), and the second removes the terms
    // and forms |W|^2.
    double a = 0, bb = 0;
    if constexpr (K > 0) {
      std::array<double, 2 * K + 2> dots{};  // y_m.next, cur.y_m, then cur.next, cur.prev
      for (std::size_t i = 0; i < n; ++i) {
        if (!free[i]) continue;
        for (int m = 0; m < K; ++m) {
          dots[m] += y[m][i] * next[i];
          dots[K + m] += cur[i] * y[m][i];
        }
        dots[2 * K] += cur[i] * next[i];
        dots[2 * K + 1] += cur[i] * prev[i];
      }
      op.reduce(dots.data(), 2 * K + 2);
      a = dots[2 * K];
      for (int m = 0; m < K; ++m) a -= dots[m] * dots[K + m];
      a -= b_prev * dots[2 * K + 1];
      for (std::size_t i = 0; i < n; ++i) {
        double w = 0.0;
        if (free[i]) {
          w = next[i];
          for (int m = 0; m < K; ++m) w -= dots[m] * y[m][i];
          w = w - b_prev * prev[i] - a * cur[i];
        }
        next[i] = w;
        bb += w * w;
      }
      op.reduce(&bb, 1);
    } else {
      const LanczosStep step = lanczos_recurrence(n, free, prev, b_prev, cur, next, op.reduce);
      a = step.alpha;
      bb = step.norm2;
    }
    if (replay) {  // the same vectors again: the recorded beta normalizes, and v_j's term of x
      const double s_j = replay->s(j);
      for (std::size_t i = 0; i < n; ++i) x[i] += s_j * cur[i];
      if (j + 1 < steps) {
        const double inv_b = 1 / replay->beta[static_cast<std::size_t>(j)];
        for (std::size_t i = 0; i < n; ++i) next[i] *= inv_b;
      }
      continue;
    }
    run.alpha.push_back(a);
    double second = 0;
    const double mu = top_ritz(run.alpha, run.beta, &run.s, &second);
    if (!(mu > 0)) break;
    run.lambda = 1 / mu;
    const double b = std::sqrt(bb);
    // The Ritz pair's residual |A x - mu x| is b |s_j|; with the gap to the next Ritz value it
    // bounds the distance of mu to an eigenvalue by r^2 / gap (Kato-Temple, the gap estimated
    // from T). Settled when that is below `settle` of mu, or when the Krylov space is one that
    // A maps into itself (W vanishes against A's scale); from a warm start also when r itself is.
    const double r = b * std::fabs(run.s(run.s.size() - 1)), gap = mu - second;
    if ((run.alpha.size() >= 3 && r * r <= settle * mu * gap) || (warm && r <= settle * mu) || !(b > 1e-12 * mu)) {
      run.settled = true;
      run.complete = true;
      break;
    }
    if (j + 1 == steps) {
      run.complete = true;
      break;
    }
    run.beta.push_back(b);
    const double inv_b = 1 / b;
    for (std::size_t i = 0; i < n; ++i) next[i] *= inv_b;
  }
  return run;
}


/** Start vectors: smooth shapes, even (shape 0) and odd (shapes 1 and 2, with other weights) about
 *  the middle (the lowest modes of a string), with per-component weights of no pattern, plus a
 *  pseudo-random tenth (another for each shape), so
 *  that every eigenvector, whatever the mix of components in it, is in the start (a smooth shape
 *  alike in every component misses the modes whose components move against each other). The same
 *  on every rank (a function of the global index). */
struct StartVector {
  const LanczosOperator& op;
  int shape;
  std::vector<double> weights;  ///< per component
  StartVector(const LanczosOperator& o, int sh) : op(o), shape(sh), weights(static_cast<std::size_t>(o.dim)) {
    for (int a = 0; a < op.dim; ++a) weights[static_cast<std::size_t>(a)] = std::cos(1.3 + 2.1 * a + 0.7 * shape);
  }
  double operator()(std::size_t i) const {
    const int node = op.first_node + static_cast<int>(i / op.dim), a = static_cast<int>(i % op.dim);
    const double s = static_cast<double>(node) / op.N;
    const double smooth = shape == 0 ? s * (1 - s) : s * (1 - s) * (1 - 2 * s);
    std::uint64_t x = (static_cast<std::uint64_t>(node) * static_cast<std::uint64_t>(op.dim) +
                       static_cast<std::uint64_t>(a) + 1) * 0x9E3779B97F4A7C15ull + static_cast<std::uint64_t>(shape);
    x ^= x >> 31;
    x *= 0xBF58476D1CE4E5B9ull;
    x ^= x >> 29;
    const double noise = static_cast<double>(x >> 11) / 9007199254740992.0 * 2 - 1;  // [-1, 1)
    return op.free[i] ? smooth * (weights[static_cast<std::size_t>(a)] + 0.1 * noise) : 0.0;
  }
};
void start_vector(const LanczosOperator& op, int shape, double* v) {
  const StartVector start(op, shape);
  for (std::size_t i = 0; i < op.n; ++i) v[i] = start(i);
}

/** The start of run `which` (0: lambda_1's, 1: lambda_2's) into v: op.start's where it gives one
 *  (true: a warm start), else start_vector's shape `which`. */
bool fill_start(const LanczosOperator& op, int which, double* v) {
  if (op.start && op.start(which, v)) return true;
  start_vector(op, which, v);
  return false;
}

/** Into z: mu x + s_k W over the free components (the refined Ritz vector, H^-1 applied to x by
 *  the Lanczos relation), x = sum_j s_j v_j given (x) or summed from the run's k vectors v_j (v_0
 *  recomputed from the built-in start where v0 is given); returns |z|^2 and z.x, reduced over the
 *  ranks. z may be x, W or one of the v_j (element by element). */
std::pair<double, double> refine_ritz(const LanczosOperator& op, const Lanczos& run, const double* x,
                                      double* const* v, const StartVector* v0, const double* W, double* z) {
  const int k = run.steps();
  const double mu = 1 / run.lambda, s_k = run.s(k - 1);
  double sums[2] = {0, 0};
  for (std::size_t i = 0; i < op.n; ++i) {
    double xi;
    if (x) {
      xi = x[i];
    } else {
      xi = run.s(0) * (v0 ? (op.free[i] ? (*v0)(i) / run.start_norm : 0.0) : v[0][i]);
      for (int j = 1; j < k; ++j) xi += run.s(j) * v[j][i];
    }
    const double zi = op.free[i] ? mu * xi + s_k * W[i] : 0.0;
    sums[0] += zi * zi;
    sums[1] += zi * xi;
    z[i] = zi;
  }
  op.reduce(sums, 2);
  return {sums[0], sums[1]};
}

}  // namespace

long fixed_components(const Grid& grid) {
  const std::size_t n = static_cast<std::size_t>(std::max(grid.N - 1, 0)) * grid.dim;
  const std::size_t dz = static_cast<std::size_t>(grid.dim);
  long fixed = 0;
  for (std::size_t i = 0; i < n; ++i) fixed += grid.is_free[dz + i] ? 0 : 1;
  return fixed;
}

SmallestEigenvalues smallest_eigenvalues(const LanczosOperator& op, long positive, bool third) {
  // lambda_1 by Lanczos on H^-1; its Ritz vector y = V s, refined by one inverse iteration, which
  // the run has already done: H^-1 y = mu y + s_k W (the Lanczos relation); then lambda_2 by
  // Lanczos on H^-1 restricted to the complement of the refined vector. The deflation keeps the
  // converged lambda_1 out of the second run: without it, a Lanczos basis that loses
  // orthogonality once lambda_1 converges returns it a second time (a "ghost"), which a lambda_1
  // far below lambda_2 (a nearly degenerate minimum) does at once. A repeated lambda_1 is found
  // again in the complement.
  // The first run's vectors cycle through the four work vectors, so that a run of up to 4 steps
  // leaves v_1 .. v_{k-1} and W in them (v_0, the normalized start vector, is recomputed where W
  // took its place): y needs no replay and no vector beyond the four. A longer run is replayed
  // from its start (k solves: its vectors and W again) with y accumulated in the fourth vector;
  // so is a warm run of 4 steps, whose start (op.start's) is not recomputed element by element.
  const std::size_t n = op.n;
  std::unique_ptr<double[]> store;
  double* w[4] = {op.work[0], op.work[1], op.work[2], op.work[3]};
  if (!(w[0] && w[1] && w[2] && w[3])) {
    store.reset(new double[4 * n]);
    for (std::size_t k = 0; k < 4; ++k) w[k] = store.get() + k * n;
  }
  SmallestEigenvalues out;
  const Basis cycle4{w, 4};
  const bool warm0 = fill_start(op, 0, cycle4.at(0));
  const Lanczos first = lanczos<0>(op, cycle4, nullptr, kSettleSmallest, warm0);
  out.lambda[0] = first.lambda;
  if (positive < 2 || first.alpha.empty()) {
    out.settled = first.settled;
    return out;
  }
  out.lambda[1] = first.lambda;  // where the refinement below fails: not settled
  if (!first.complete) return out;
  const int k = first.steps();
  // z = mu y + s_k W, element by element, written over v_0 (or W, where W took v_0's place): y
  // and z are then in w[0]. With a replay, y and z in w[3] and W in the replay's cycle of three.
  const bool replayed = k > 4 || (warm0 && k == 4);
  double* z_out = w[0];
  std::pair<double, double> sums;
  if (replayed) {
    const Basis cycle3{w, 3};
    fill_start(op, 0, cycle3.at(0));
    lanczos<0>(op, cycle3, nullptr, 0, warm0, &first, w[3]);
    z_out = w[3];
    sums = refine_ritz(op, first, w[3], nullptr, nullptr, cycle3.at(k), z_out);
  } else {
    const StartVector start(op, 0);
    sums = refine_ritz(op, first, nullptr, w, k == 4 ? &start : nullptr, cycle4.at(k), z_out);
  }
  const double zz = sums.first, zy = sums.second;
  // The Rayleigh quotient of H at z, z.H z / z.z = z.y / z.z (H z = y), is an upper bound on
  // lambda_1 whose error is the square of z's angle to the eigenvector (a factor lambda_1 /
  // lambda_2 below y's), and z/|z| is the vector deflated below.
  if (!(zz > 0) || !std::isfinite(zz)) return out;
  if (zy > 0) out.lambda[0] = std::min(out.lambda[0], zy / zz);
  const double nz = std::sqrt(zz);
  double* y = z_out;
  for (std::size_t i = 0; i < n; ++i) y[i] /= nz;
  if (op.keep[0]) {
    std::copy(y, y + n, op.keep[0]);
    out.kept[0] = true;
  }
  double* rest[3];
  for (int j = 0, r = 0; j < 4; ++j)
    if (w[j] != y) rest[r++] = w[j];
  const Basis second_basis{rest, 3};
  const bool warm1 = fill_start(op, 1, second_basis.at(0));
  const Lanczos second = lanczos<1>(op, second_basis, &y, kSettleNext, warm1);
  // A second value below the first: the first run's start lay along a higher mode (a warm start
  // from a coarse level where two modes were in the other order), and the two swap.
  const bool swapped = second.lambda > 0 && second.lambda < out.lambda[0];
  if (swapped) {
    out.lambda[1] = out.lambda[0];
    out.lambda[0] = second.lambda;
  } else {
    out.lambda[1] = std::max(second.lambda, first.lambda);
  }
  out.settled = first.settled && second.settled;
  // Two nearly equal smallest values (a repeated lowest mode): lambda_3 as well, where asked.
  const bool repeated = third && positive >= 3 && second.complete && second.lambda > 0 &&
                        lowest_two_close(out.lambda[0], out.lambda[1]);
  // The second Ritz vector, into op.keep[1] where given, else (for lambda_3's run) a vector of
  // its own.
  std::unique_ptr<double[]> own;
  double* x2 = op.keep[1];
  if (!x2 && repeated) {
    own.reset(new double[n]);
    x2 = own.get();
  }
  if (x2 && second.complete && second.lambda > 0) {
    // Refined as the first: from the vectors at hand after up to 2 steps (W took v_0's place
    // after 3), else by a replay that sums it in x2.
    const int k2 = second.steps();
    if (k2 <= 2) {
      refine_ritz(op, second, nullptr, rest, nullptr, second_basis.at(k2), x2);
    } else {
      fill_start(op, 1, second_basis.at(0));
      lanczos<1>(op, second_basis, &y, 0, warm1, &second, x2);
      refine_ritz(op, second, x2, nullptr, nullptr, second_basis.at(k2), x2);
    }
    out.kept[1] = op.keep[1] != nullptr;
  }
  // lambda_3 by Lanczos on H^-1 restricted to the complement of both refined vectors (x2 made
  // orthonormal to y first), from the built-in start of shape 2, in the three vectors of the
  // second run: an upper bound on the third eigenvalue up to the errors of the two vectors, as
  // lambda_2 is on the second.
  if (repeated && deflate<1>(op, x2, &y) > 0) {
    const double* both[2] = {y, x2};
    start_vector(op, 2, second_basis.at(0));
    const Lanczos third_run = lanczos<2>(op, second_basis, both, kSettleNext, false);
    if (third_run.lambda > 0) {
      out.lambda[2] = std::max(third_run.lambda, out.lambda[1]);
      out.settled_third = third_run.settled;
    }
  }
  if (swapped && out.kept[0] && out.kept[1]) std::swap_ranges(op.keep[0], op.keep[0] + n, op.keep[1]);
  return out;
}

bool notes_round_off_bound(double lambda_min, double lambda_max) {
  return lambda_min > 0 && lambda_max / lambda_min * 1e-16 > 1e-3;
}

void describe_minimum(const SmallestEigenvalues& e, double action, PointAssessment& out, double diagonal_spread) {
  out.kind = PointKind::minimum;
  out.lambda_min = e.lambda[0];
  out.lambda_next = e.lambda[1];
  out.lambda_settled = e.settled;
  // A lowest mode of multiplicity two or more (an isotropic oscillator at a conjugate time) has
  // lambda_next next to lambda_min; the gap that shows a nearly degenerate minimum then lies above
  // lambda_next, and smallest_eigenvalues gives lambda_3 there.
  const bool repeated = out.positive >= 2 && lowest_two_close(out.lambda_min, out.lambda_next);
  const double lambda3 = repeated && out.positive >= 3 ? e.lambda[2] : 0.0;
  const double soft_motion =
      std::sqrt(2 * 1e-16 * std::max(std::fabs(action), 1e-300) / std::max(out.lambda_min, 1e-300));
  if (out.positive >= 2 && out.lambda_min < 1e-4 * out.lambda_next) {
    out.nearly_degenerate = true;
    out.soft_motion = soft_motion;
    out.note = format("a nearly degenerate minimum: the smallest eigenvalue of the Hessian, %.3g, is %.2g of the "
                      "next (%.3g); the action is determined to round-off, the trajectory only up to a motion of "
                      "size about %.2g along one direction",
                      out.lambda_min, out.lambda_min / out.lambda_next, out.lambda_next, out.soft_motion);
  } else if (lambda3 > 0 && out.lambda_next < 1e-4 * lambda3) {
    out.nearly_degenerate = true;
    out.soft_motion = soft_motion;
    out.note = format("a nearly degenerate minimum whose lowest mode is two-fold: the two smallest eigenvalues of the "
                      "Hessian, %.3g and %.3g, lie within a factor 2 of each other and the second is %.2g of the "
                      "third (%.3g); the action is determined to round-off, the trajectory only up to a motion of "
                      "size about %.2g in a two-dimensional subspace",
                      out.lambda_min, out.lambda_next, out.lambda_next / lambda3, lambda3, out.soft_motion);
  } else if (out.lambda_settled) {
    out.note = format("a strict local minimum: Hessian positive definite, eigenvalues from %.3g (next %.3g) to at "
                      "most %.3g",
                      out.lambda_min, out.lambda_next, out.lambda_max);
  } else {
    out.note = format("a strict local minimum: Hessian positive definite, eigenvalues from at most %.3g (next at "
                      "most %.3g) to at most %.3g",
                      out.lambda_min, out.lambda_next, out.lambda_max);
  }
  if (repeated && !out.nearly_degenerate) {
    if (!(lambda3 > 0))  // one or two unknowns, or the third run failed
      out.note += "; the two smallest eigenvalues lie within a factor 2 of each other (as a repeated lowest mode "
                  "makes them), so their ratio does not tell whether the minimum is nearly degenerate: compare "
                  "lambda_min with the problem's own scales";
    else if (lambda3 < 2 * out.lambda_next)
      out.note += format("; the three smallest eigenvalues lie within factors 2 of each other (the third %.3g), so "
                         "their ratios do not tell whether the minimum is nearly degenerate: compare lambda_min with "
                         "the problem's own scales",
                         lambda3);
    else
      out.note += format("; the two smallest eigenvalues lie within a factor 2 of each other (as a two-fold lowest mode "
                         "makes them), and the third, %.3g, is %.3g times the second, short of the factor 1e4 that "
                         "marks a nearly degenerate minimum",
                         lambda3, lambda3 / out.lambda_next);
  }
  if (!out.lambda_settled)
    out.note += format("; the two smallest are upper bounds: Ritz values of %.0f Lanczos steps that had not "
                       "settled",
                       static_cast<double>(kLanczosSteps));
  if (lambda3 > 0 && !e.settled_third)
    out.note += format("; the third is an upper bound: the Ritz value of %.0f Lanczos steps that had not settled",
                       static_cast<double>(kLanczosSteps));
  if (notes_round_off_bound(out.lambda_min, out.lambda_max)) {
    const double condition = out.lambda_max / out.lambda_min;
    out.note += format("; the Hessian's condition number is about %.2g, so round-off alone can move the trajectory by "
                       "up to %.2g relative in a double-precision solve",
                       condition, condition * 1e-16);
    if (diagonal_spread > kStallSpread)
      out.note += format(" (a bound over all coordinates in one norm: the Hessian's diagonal spans a factor %.2g, and "
                         "in their own units the coordinates can move far less)",
                         diagonal_spread);
  }
}

namespace {

/** The Lanczos operator of ctx's free unknowns in one process, through `solve`. */
LanczosOperator local_operator(const Context& ctx, const std::function<void(const double* b, double* x)>& solve,
                               double* const* work) {
  LanczosOperator op;
  op.n = static_cast<std::size_t>(std::max(ctx.N - 1, 0)) * static_cast<std::size_t>(ctx.dim);
  op.dim = ctx.dim;
  op.first_node = 1;
  op.N = ctx.N;
  op.free = ctx.is_free.data() + ctx.dim;
  op.solve = solve;
  op.reduce = [](double*, int) {};
  if (work)
    for (int k = 0; k < 4; ++k) op.work[k] = work[k];
  return op;
}

}  // namespace

void assess_minimum(Context& ctx, double lambda_max, const std::function<void(const double* b, double* x)>& solve,
                    PointAssessment& out, double* const* work, const LevelEigenvectors* from) {
  out = PointAssessment{};
  out.lambda_max = lambda_max;
  out.positive = static_cast<long>(std::max(ctx.N - 1, 0)) * ctx.dim - fixed_components(ctx);
  out.kind = PointKind::minimum;
  if (out.positive <= 0) {
    out.note = "no unknowns";
    return;
  }
  // An interruption after convergence stops the assessment at its next block solve.
  struct Interrupted {};
  LanczosOperator op = local_operator(
      ctx,
      [&solve, &ctx](const double* b, double* x) {
        if (ctx.keep_going && !ctx.keep_going()) throw Interrupted{};
        solve(b, x);
      },
      work);
  if (from && from->held()) op.start = [from, &ctx](int which, double* v) { return from->start(ctx, which, v); };
  try {
    const SmallestEigenvalues e = smallest_eigenvalues(op, out.positive);
    // The spread only where the note gives the round-off bound (a pass over the nodes).
    describe_minimum(e, sum_action(ctx), out,
                     notes_round_off_bound(e.lambda[0], lambda_max) ? diagonal_spread(ctx) : 1.0);
  } catch (const Interrupted&) {
    out = PointAssessment{};
    out.note = "not assessed: interrupted during the assessment of the converged point";
  }
}

void LevelEigenvectors::settle_level(const Context& ctx, const std::function<void(const double* b, double* x)>& solve,
                                     double* const* work) {
  LanczosOperator op = local_operator(ctx, solve, work);
  const long positive = static_cast<long>(op.n) - fixed_components(ctx);
  if (positive <= 0) {
    valid_[0] = valid_[1] = false;
    return;
  }
  for (int i = 0; i < 2; ++i) {
    next_[i].resize(op.n);
    op.keep[i] = next_[i].data();
  }
  if (held()) op.start = [this, &ctx](int which, double* v) { return start(ctx, which, v); };
  const SmallestEigenvalues e = smallest_eigenvalues(op, positive, false);
  for (int i = 0; i < 2; ++i) {
    std::swap(v_[i], next_[i]);
    valid_[i] = e.kept[i];
  }
  N_ = ctx.N;
  dim_ = ctx.dim;
  t_.assign(ctx.t.begin(), ctx.t.begin() + ctx.N + 1);
}

bool LevelEigenvectors::start(const Context& ctx, int which, double* v) const {
  if (!valid_[which] || dim_ != ctx.dim || N_ < 2 || ctx.N < 2) return false;
  const std::vector<double>& c = v_[which];
  const std::size_t d = static_cast<std::size_t>(dim_);
  const unsigned char* free = ctx.is_free.data() + d;
  // Coarse interior node m (1 .. N_ - 1) holds c[(m - 1) d + a]; the fine node j's value comes
  // from the coarse interval [m, m + 1] that holds its time, m kept within 1 .. N_ - 2 (linear
  // extrapolation past the ends; one interior node: its value).
  int m = 1;
  for (int j = 1; j < ctx.N; ++j) {
    const double t = ctx.t[static_cast<std::size_t>(j)];
    while (m + 1 < N_ - 1 && t > t_[static_cast<std::size_t>(m + 1)]) ++m;
    const std::size_t lo = static_cast<std::size_t>(m - 1) * d;
    double* out = v + static_cast<std::size_t>(j - 1) * d;
    if (N_ == 2) {
      for (std::size_t a = 0; a < d; ++a) out[a] = c[a];
    } else {
      const double t0 = t_[static_cast<std::size_t>(m)], t1 = t_[static_cast<std::size_t>(m + 1)];
      const double f = (t - t0) / (t1 - t0);
      for (std::size_t a = 0; a < d; ++a) out[a] = c[lo + a] + f * (c[lo + d + a] - c[lo + a]);
    }
    for (std::size_t a = 0; a < d; ++a)
      if (!free[static_cast<std::size_t>(j - 1) * d + a]) out[a] = 0;
  }
  return true;
}

bool classify_indefinite(PointAssessment& out) {
  if (out.negative > 0) {
    out.kind = PointKind::saddle;
    out.note = format("a saddle of the action: the Hessian has %.0f negative eigenvalue(s) (index %.0f)",
                      static_cast<double>(out.negative), static_cast<double>(out.negative));
    if (out.zero > 0) out.note += format(" and %.0f zero one(s)", static_cast<double>(out.zero));
    if (out.positive <= 0 && out.zero <= 0) out.note += "; every eigenvalue is negative: a local maximum of the action";
    return true;
  }
  if (out.zero > 0) {
    out.kind = PointKind::degenerate;
    out.note = format("degenerate to working precision: the Hessian of the action has %.0f eigenvalue(s) that "
                      "are zero within 1e-12 of its largest (Jacobi-scaled) and no negative one; either the solution is not "
                      "isolated (a family of trajectories, or a Lagrangian that does not determine the motion) "
                      "or the Hessian is too ill-conditioned for double precision to tell (high-order models "
                      "at large N)",
                      static_cast<double>(out.zero));
    return true;
  }
  return false;
}

Inertia interior_inertia(const Context& ctx, int first, int count) {
  Inertia total;
  const int M = ctx.disc ? ctx.disc->interior_size : 0;
  const pardel_interior_hessian_kernel kernel = ctx.disc ? ctx.disc->interior_hessian : nullptr;
  if (M <= 0 || !kernel || count <= 0) return total;
  long positive = 0, negative = 0, zero = 0;
  const std::size_t d = static_cast<std::size_t>(ctx.dim);
  const double* p = ctx.p();
#pragma omp parallel if (ctx.parallel(count)) num_threads(ctx.threads) reduction(+ : positive, negative, zero)
  {
    // One block and eigensolver a thread, sized once.
    Eigen::MatrixXd H(M, M);
    Eigen::VectorXd J(M);
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(M);
#pragma omp for schedule(static)
    for (int i = 0; i < count; ++i) {
      const std::size_t k = static_cast<std::size_t>(first + i);
      kernel(ctx.hk[k], ctx.t[k], ctx.t[k + 1], ctx.q.data() + k * d, ctx.q.data() + (k + 1) * d, p, H.data());
      if (!H.allFinite()) {
        zero += M;
        continue;
      }
      // Row-major or column-major alike: H is symmetric. The congruence J H J keeps its inertia;
      // formed in place, with Gershgorin's bound of the result (no temporary a block).
      for (int a = 0; a < M; ++a) J[a] = jacobi_scale(H(a, a));
      double bound = 0;
      for (int a = 0; a < M; ++a) {
        double row = 0;
        for (int b = 0; b < M; ++b) row += std::fabs(H(a, b) *= J[a] * J[b]);
        bound = std::max(bound, row);
      }
      const double tiny = zero_threshold(bound);
      eigen.compute(H, Eigen::EigenvaluesOnly);
      if (eigen.info() != Eigen::Success) {
        zero += M;
        continue;
      }
      for (int a = 0; a < M; ++a) {
        const double v = eigen.eigenvalues()[a];
        if (v > tiny)
          ++positive;
        else if (v < -tiny)
          ++negative;
        else
          ++zero;
      }
    }
  }
  total.positive = positive;
  total.negative = negative;
  total.zero = zero;
  return total;
}

void add_interior_inertia(const Inertia& interior, PointAssessment& out) {
  if (out.kind == PointKind::unknown) return;  // not assessed
  out.positive += interior.positive;
  if (interior.negative == 0 && interior.zero == 0) return;
  const bool was_minimum = out.kind == PointKind::minimum;
  const long negative = out.negative + interior.negative, zero = out.zero + interior.zero;
  const double lambda_max = out.lambda_max;
  const long positive = out.positive;
  out = PointAssessment{};
  out.positive = positive;
  out.negative = negative;
  out.zero = zero;
  out.lambda_max = lambda_max;
  classify_indefinite(out);
  out.note += format("; %.0f negative and %.0f zero of them in the intervals' interior values (the Hessian over "
                     "nodes and interior values",
                     static_cast<double>(interior.negative), static_cast<double>(interior.zero));
  out.note += was_minimum ? std::string(", whose node part, the condensed action's, is positive definite)") : ")";
}

void note_residual_caveats(double residual, double floor, double scale, PointAssessment& out) {
  // Where round-off in the DEL terms is as large as the terms (high orders at large N), the
  // elimination's negative pivots need not be the Hessian's: a minimum's note gives its
  // condition, a saddle's says this.
  if (out.kind == PointKind::saddle && scale > 0 && 10 * floor >= scale)
    out.note +=
        "; but at this N round-off in the DEL terms is as large as the terms themselves, and the Hessian is "
        "beyond double precision: the negative eigenvalues (and so whether the point is a saddle at all) are "
        "not resolved; a smaller N resolves them";
  // At a discrete conjugate point of the end values the iterates walk along the zero direction
  // until the residual is small next to their own terms.
  constexpr double kFarAboveRoundOff = 1e3;
  if (out.kind == PointKind::degenerate && floor > 0 && residual > kFarAboveRoundOff * floor)
    out.note += format(
        "; and the DEL residual %.3g is %.2g times its round-off level: along the zero direction(s) the tolerance "
        "(relative to the DEL terms' scale %.3g, taken at this iterate) leaves the trajectory undetermined, and "
        "where the discrete problem is singular there (a discrete conjugate point of these end values) it may "
        "have no solution near here at all",
        residual, residual / floor, scale);
}

namespace {

/** Calls f(H) with H the unshifted Hessian at ctx.q, assembled (the full kernel evaluated there
 *  where ctx lacks it); false, without calling f, for N < 2 or an entry of H that is not finite
 *  (a second derivative of L at a fixed end, where L may be singular, does not enter H). */
template <class F>
bool with_hessian(Context& ctx, F&& f) {
  if (ctx.N < 2) return false;
  ensure_interval_arrays(ctx, Evaluated::full);
  if (ctx.evaluated != Evaluated::full) eval_full(ctx, ctx.q);
  bool finite = true;
  dispatch_dim_cold(ctx.dim, [&](auto D) {
    BlockTridiagonal<decltype(D)::value> H;
    H.resize(ctx.N, ctx.dim);
    H.assemble(ctx, 0.0);
    finite = H.all_finite();
    if (finite) f(H);
  });
  return finite;
}

}  // namespace

void assess(Context& ctx, PointAssessment& out) {
  out = PointAssessment{};
  if (!with_hessian(ctx, [&](auto& H) { assess_hessian(ctx, H, false, out); }))
    out.note = ctx.N < 2 ? "not assessed: no interior node"
                         : "not assessed: the Hessian of the action has an entry that is not finite at this point";
}

bool newton_correction(Context& ctx, std::vector<double>& delta) {
  bool solved = false;
  with_hessian(ctx, [&](auto& H) {
    if (!H.factor_ldlt() && !H.factor_indefinite()) return;
    // The DEL residual at ctx.q, evaluated here: a method may end without writing ctx.res (the
    // fused Jacobi sweeps keep only its norm), and a stale or zero res would make the correction,
    // and the error estimate from it, zero.
    if (compute_residual(ctx) >= 0) return;
    extend_residual(ctx);
    H.newton_correction(ctx, delta);
    solved = true;
  });
  return solved;
}

bool lagrangian_regular(const Context& ctx, std::string* message) {
  // Up to 64 intervals spread over the grid, each evaluated alone with the full kernel, until one
  // has a regular D12 (the model is refused only when every one of them is singular).
  const int d = ctx.dim, N = ctx.N;
  const std::size_t dz = static_cast<std::size_t>(d), dd = dz * dz;
  std::vector<double> D1(dz), D2(dz), D11(dd), D12(dd), D22(dd);
  const int samples = std::min(N, 64);
  for (int s = 0; s < samples; ++s) {
    const int k = static_cast<int>((static_cast<long>(s) * N) / samples);
    const std::size_t kk = static_cast<std::size_t>(k);
    double Ld = 0;
    ctx.disc->full(ctx.hk[kk], ctx.t[kk], ctx.t[kk + 1], ctx.q.data() + kk * dz, ctx.q.data() + (kk + 1) * dz, ctx.p(),
                   &Ld, D1.data(), D2.data(), D11.data(), D12.data(), D22.data());
    bool finite = true;
    for (double v : D12) finite = finite && std::isfinite(v);
    if (!finite) return true;  // non-finite values are reported by the solve itself
    // Component i of a point is the k_i = (i / ncoords)-th derivative, and the entries of D12
    // pairing derivatives k and l scale like h^(k + l + 1 - 2 order): D12 is equilibrated by
    // h^-(k_i + k_j) before its singular values are compared (unscaled, their spread at order 4
    // fell below 1e-12 at h = 1/16 on a regular model; scaled it is 6e-6 at every h).
    const int nc = std::max(ctx.model->ncoords, 1);
    const double h = std::fabs(ctx.hk[kk]) > 0 ? std::fabs(ctx.hk[kk]) : 1.0;
    for (int i = 0; i < d; ++i)
      for (int j = 0; j < d; ++j) D12[static_cast<std::size_t>(i * d + j)] *= std::pow(h, -(i / nc + j / nc));
    // Then rows and columns by their largest entries (the rank is unchanged): coordinates in units
    // whose terms differ by 10^12 (W = diag(1e12, 1)) are not taken for a singular D12.
    equilibrate(D12.data(), d);
    if (!(relative_smallest_singular_value(D12.data(), d) <= kSingularD12)) return true;
  }
  *message = "model '" + std::string(ctx.model->name ? ctx.model->name : "?") +
             "' is degenerate: the mixed derivative D12 Ld of its discrete Lagrangian is singular on every one of the " +
             std::to_string(samples) +
             " intervals checked at the initial guess, so the DEL equations do not determine the motion "
             "(the Lagrangian's Hessian in the highest derivatives is singular: does L depend on the "
             "derivatives of every coordinate?)";
  return false;
}

}  // namespace pardel::detail

namespace pardel {

PointAssessment assess_point(const Problem& problem, const Trajectory& trajectory, int threads) {
  PointAssessment out;
  detail::Context ctx;
  std::string error;
  if (!detail::context_at(problem, trajectory, threads, ctx, &error)) {
    out.note = error;
    return out;
  }
  detail::assess(ctx, out);
  if (detail::beyond_double(out)) detail::assess_extended(ctx, out);  // as a solve's own assessment
  detail::add_interior_inertia(detail::interior_inertia(ctx, 0, ctx.N), out);
  return out;
}

}  // namespace pardel
