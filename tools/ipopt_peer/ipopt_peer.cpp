/**
 * @file ipopt_peer.cpp
 * The IPOPT peer: a TNLP over the free components of the interior nodes whose objective is the
 * discrete action, with the gradient and the exact (block-tridiagonal) Hessian assembled from the
 * generated kernels of the model.
 */
#include "ipopt_peer.hpp"

#include <IpIpoptApplication.hpp>
#include <IpSolveStatistics.hpp>
#include <IpTNLP.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

namespace pardel::peer {
namespace {

const pardel_discretization* discretization_of(const Problem& problem) {
  if (problem.discretization) return problem.discretization;
  if (problem.model && problem.model->ndiscretizations > 0) return &problem.model->discretizations[0];
  return nullptr;
}

/** Everything the kernels need, checked once: grid, parameters, fixed components. */
struct Grid {
  const pardel_model* model = nullptr;
  const pardel_discretization* disc = nullptr;
  int N = 0, dim = 0;
  double h = 0, t0 = 0;
  std::vector<double> params;
  std::vector<long> var;  ///< (N+1)*dim: index of the unknown, or -1 where the component is fixed
  long nvars = 0;
  const double* p() const { return params.empty() ? nullptr : params.data(); }
  double t(int k) const { return t0 + h * k; }
};

bool build_grid(const Problem& problem, Grid& g, std::string* error) {
  std::ostringstream e;
  if (!problem.model) {
    *error = "problem.model is null";
    return false;
  }
  const pardel_model& m = *problem.model;
  g.model = &m;
  g.disc = discretization_of(problem);
  if (!g.disc) {
    *error = "model '" + std::string(m.name) + "' has no discretization";
    return false;
  }
  if (problem.N < 2) {
    e << "problem.N = " << problem.N << " must be at least 2";
    *error = e.str();
    return false;
  }
  if (!(problem.T > 0) || !std::isfinite(problem.T)) {
    e << "problem.T = " << problem.T << " must be positive and finite";
    *error = e.str();
    return false;
  }
  if (problem.clock != ClockMode::none) {
    *error = "problem.clock: the IPOPT peer supports fixed node times only (clock none)";
    return false;
  }
  g.dim = m.dim;
  g.N = problem.N;
  g.h = problem.T / problem.N;
  g.t0 = problem.t0;
  if (problem.q0.size() != static_cast<std::size_t>(g.dim) ||
      problem.qN.size() != static_cast<std::size_t>(g.dim)) {
    e << "problem.q0 and problem.qN must have dim = " << g.dim << " values (have " << problem.q0.size()
      << " and " << problem.qN.size() << ")";
    *error = e.str();
    return false;
  }
  if (problem.params.empty()) {
    g.params.assign(m.param_defaults, m.param_defaults + m.nparams);
  } else if (problem.params.size() == static_cast<std::size_t>(m.nparams)) {
    g.params = problem.params;
  } else {
    e << "problem.params has " << problem.params.size() << " values, model '" << m.name << "' declares "
      << m.nparams;
    *error = e.str();
    return false;
  }
  const std::size_t total = static_cast<std::size_t>(g.N + 1) * g.dim;
  g.var.assign(total, 0);
  for (int a = 0; a < g.dim; ++a) {
    g.var[static_cast<std::size_t>(a)] = -1;
    g.var[static_cast<std::size_t>(g.N) * g.dim + a] = -1;
  }
  for (std::size_t i = 0; i < problem.knots.size(); ++i) {
    const Knot& knot = problem.knots[i];
    const double s = (knot.t - g.t0) / g.h;
    const long k = std::lround(s);
    if (std::fabs(s - k) > 1e-9 * std::max(1.0, std::fabs(s)) || k < 1 || k > g.N - 1) {
      e << "problem.knots[" << i << "].t = " << knot.t << " is not an interior grid node";
      *error = e.str();
      return false;
    }
    if (knot.q.size() != static_cast<std::size_t>(m.ncoords)) {
      e << "problem.knots[" << i << "].q must have ncoords = " << m.ncoords << " values";
      *error = e.str();
      return false;
    }
    for (int a = 0; a < m.ncoords; ++a) g.var[static_cast<std::size_t>(k) * g.dim + a] = -1;
  }
  long n = 0;
  for (std::size_t i = 0; i < total; ++i)
    if (g.var[i] >= 0) g.var[i] = n++;
  g.nvars = n;
  return true;
}

/** Writes the boundary and knot values into trajectory; checks its shape. */
bool pin_fixed(const Problem& problem, const Grid& g, Trajectory& tr, std::string* error) {
  if (tr.N != g.N || tr.dim != g.dim ||
      tr.q.size() != static_cast<std::size_t>(g.N + 1) * g.dim) {
    std::ostringstream e;
    e << "trajectory has N = " << tr.N << ", dim = " << tr.dim << " and " << tr.q.size()
      << " values; the problem needs N = " << g.N << ", dim = " << g.dim;
    *error = e.str();
    return false;
  }
  for (int a = 0; a < g.dim; ++a) {
    tr.node(0)[a] = problem.q0[static_cast<std::size_t>(a)];
    tr.node(g.N)[a] = problem.qN[static_cast<std::size_t>(a)];
  }
  for (const Knot& knot : problem.knots) {
    const long k = std::lround((knot.t - g.t0) / g.h);
    for (int a = 0; a < g.model->ncoords; ++a) tr.node(static_cast<int>(k))[a] = knot.q[static_cast<std::size_t>(a)];
  }
  tr.t.resize(static_cast<std::size_t>(g.N) + 1);
  for (int k = 0; k <= g.N; ++k) tr.t[static_cast<std::size_t>(k)] = g.t(k);
  return true;
}

/** Gradient arrays of every interval at q: Ld (N), D1 and D2 (N*dim). */
void eval_grad(const Grid& g, const double* q, int threads, std::vector<double>& Ld, std::vector<double>& D1,
               std::vector<double>& D2) {
  const int d = g.dim;
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int k = 0; k < g.N; ++k) {
    const std::size_t o = static_cast<std::size_t>(k) * d;
    g.disc->grad(g.h, g.t(k), g.t(k + 1), q + o, q + o + d, g.p(), &Ld[static_cast<std::size_t>(k)], &D1[o], &D2[o]);
  }
}

double fixed_sum(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s;
}

double residual_from(const Grid& g, const std::vector<double>& D1, const std::vector<double>& D2) {
  double r = 0;
  const int d = g.dim;
  for (int k = 1; k < g.N; ++k) {
    for (int a = 0; a < d; ++a) {
      const std::size_t i = static_cast<std::size_t>(k) * d + a;
      if (g.var[i] < 0) continue;
      const double v = std::fabs(D2[i - d] + D1[i]);
      if (!(v <= r)) r = v;  // NaN propagates
    }
  }
  return r;
}

/** One lower-triangle Hessian entry: value = A[ia] (+ B[ib] when ib >= 0). */
struct HessEntry {
  int kind;  ///< 0: D22[ia] + D11[ib] (diagonal block), 1: D12[ia] (off-diagonal block)
  long ia, ib;
};

class ActionNlp : public Ipopt::TNLP {
 public:
  ActionNlp(const Grid& g, std::vector<double>& q, int threads) : g_(g), q_(q), threads_(threads) {
    const std::size_t N = static_cast<std::size_t>(g.N), d = static_cast<std::size_t>(g.dim);
    Ld_.resize(N);
    D1_.resize(N * d);
    D2_.resize(N * d);
    D11_.resize(N * d * d);
    D12_.resize(N * d * d);
    D22_.resize(N * d * d);
    work_ = q;
    // Sparsity of the lower triangle: diagonal blocks, then the block below each.
    for (int k = 1; k < g.N; ++k) {
      for (int a = 0; a < g.dim; ++a) {
        const long ra = g.var[static_cast<std::size_t>(k) * d + a];
        if (ra < 0) continue;
        for (int b = 0; b < g.dim; ++b) {
          const long cb = g.var[static_cast<std::size_t>(k) * d + b];
          if (cb < 0 || cb > ra) continue;
          const long ab = static_cast<long>(a) * g.dim + b;
          rows_.push_back(ra);
          cols_.push_back(cb);
          entries_.push_back({0, static_cast<long>((k - 1) * d * d) + ab, static_cast<long>(k * d * d) + ab});
        }
      }
      if (k + 1 >= g.N) continue;
      // d^2 Ld_k / (dq_{k+1,b} dq_{k,a}) = D12(k)[a*dim + b]; row = (k+1, b), column = (k, a).
      for (int b = 0; b < g.dim; ++b) {
        const long rb = g.var[static_cast<std::size_t>(k + 1) * d + b];
        if (rb < 0) continue;
        for (int a = 0; a < g.dim; ++a) {
          const long ca = g.var[static_cast<std::size_t>(k) * d + a];
          if (ca < 0) continue;
          rows_.push_back(rb);
          cols_.push_back(ca);
          entries_.push_back({1, static_cast<long>(k * d * d) + static_cast<long>(a) * g.dim + b, -1});
        }
      }
    }
  }

  long nonzeros() const { return static_cast<long>(entries_.size()); }
  Ipopt::SolverReturn solver_status() const { return status_; }

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g, Ipopt::Index& nnz_h_lag,
                    IndexStyleEnum& index_style) override {
    n = static_cast<Ipopt::Index>(g_.nvars);
    m = 0;
    nnz_jac_g = 0;
    nnz_h_lag = static_cast<Ipopt::Index>(entries_.size());
    index_style = C_STYLE;
    return true;
  }

  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index, Ipopt::Number*,
                       Ipopt::Number*) override {
    for (Ipopt::Index i = 0; i < n; ++i) {
      x_l[i] = -2e19;
      x_u[i] = 2e19;
    }
    return true;
  }

  bool get_starting_point(Ipopt::Index, bool init_x, Ipopt::Number* x, bool, Ipopt::Number*, Ipopt::Number*,
                          Ipopt::Index, bool, Ipopt::Number*) override {
    if (init_x) {
      for (std::size_t i = 0; i < g_.var.size(); ++i)
        if (g_.var[i] >= 0) x[g_.var[i]] = q_[i];
    }
    return true;
  }

  bool eval_f(Ipopt::Index, const Ipopt::Number* x, bool new_x, Ipopt::Number& obj_value) override {
    load(x, new_x);
    if (!grad_valid_) {
      const double* q = work_.data();
      const int d = g_.dim;
#pragma omp parallel for num_threads(threads_) schedule(static)
      for (int k = 0; k < g_.N; ++k) {
        const std::size_t o = static_cast<std::size_t>(k) * d;
        Ld_[static_cast<std::size_t>(k)] = g_.disc->action(g_.h, g_.t(k), g_.t(k + 1), q + o, q + o + d, g_.p());
      }
    }
    obj_value = fixed_sum(Ld_);
    return std::isfinite(obj_value);
  }

  bool eval_grad_f(Ipopt::Index, const Ipopt::Number* x, bool new_x, Ipopt::Number* grad_f) override {
    load(x, new_x);
    if (!grad_valid_) {
      eval_grad(g_, work_.data(), threads_, Ld_, D1_, D2_);
      grad_valid_ = true;
    }
    const int d = g_.dim;
    for (int k = 1; k < g_.N; ++k)
      for (int a = 0; a < d; ++a) {
        const std::size_t i = static_cast<std::size_t>(k) * d + a;
        if (g_.var[i] >= 0) grad_f[g_.var[i]] = D2_[i - d] + D1_[i];
      }
    return true;
  }

  bool eval_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Number*) override { return true; }

  bool eval_jac_g(Ipopt::Index, const Ipopt::Number*, bool, Ipopt::Index, Ipopt::Index, Ipopt::Index*,
                  Ipopt::Index*, Ipopt::Number*) override {
    return true;
  }

  bool eval_h(Ipopt::Index, const Ipopt::Number* x, bool new_x, Ipopt::Number obj_factor, Ipopt::Index,
              const Ipopt::Number*, bool, Ipopt::Index nele_hess, Ipopt::Index* iRow, Ipopt::Index* jCol,
              Ipopt::Number* values) override {
    if (!values) {
      for (Ipopt::Index i = 0; i < nele_hess; ++i) {
        iRow[i] = static_cast<Ipopt::Index>(rows_[static_cast<std::size_t>(i)]);
        jCol[i] = static_cast<Ipopt::Index>(cols_[static_cast<std::size_t>(i)]);
      }
      return true;
    }
    load(x, new_x);
    if (!hess_valid_) {
      const double* q = work_.data();
      const int d = g_.dim;
      const std::size_t dd = static_cast<std::size_t>(d) * d;
#pragma omp parallel for num_threads(threads_) schedule(static)
      for (int k = 0; k < g_.N; ++k) {
        const std::size_t kk = static_cast<std::size_t>(k);
        g_.disc->full(g_.h, g_.t(k), g_.t(k + 1), q + kk * d, q + (kk + 1) * d, g_.p(), &Ld_[kk], &D1_[kk * d],
                      &D2_[kk * d], &D11_[kk * dd], &D12_[kk * dd], &D22_[kk * dd]);
      }
      hess_valid_ = grad_valid_ = true;
    }
    for (std::size_t i = 0; i < entries_.size(); ++i) {
      const HessEntry& e = entries_[i];
      const double v = e.kind == 0 ? D22_[static_cast<std::size_t>(e.ia)] + D11_[static_cast<std::size_t>(e.ib)]
                                   : D12_[static_cast<std::size_t>(e.ia)];
      values[i] = obj_factor * v;
    }
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn status, Ipopt::Index, const Ipopt::Number* x, const Ipopt::Number*,
                         const Ipopt::Number*, Ipopt::Index, const Ipopt::Number*, const Ipopt::Number*,
                         Ipopt::Number, const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    status_ = status;
    for (std::size_t i = 0; i < g_.var.size(); ++i)
      if (g_.var[i] >= 0) q_[i] = x[g_.var[i]];
  }

 private:
  void load(const Ipopt::Number* x, bool new_x) {
    if (!new_x && loaded_) return;
    for (std::size_t i = 0; i < g_.var.size(); ++i)
      if (g_.var[i] >= 0) work_[i] = x[g_.var[i]];
    loaded_ = true;
    grad_valid_ = hess_valid_ = false;
  }

  const Grid& g_;
  std::vector<double>& q_;  ///< the caller's trajectory values: fixed components and the result
  int threads_;
  std::vector<double> work_;  ///< the point being evaluated, fixed components included
  std::vector<double> Ld_, D1_, D2_, D11_, D12_, D22_;
  std::vector<long> rows_, cols_;
  std::vector<HessEntry> entries_;
  bool loaded_ = false, grad_valid_ = false, hess_valid_ = false;
  Ipopt::SolverReturn status_ = Ipopt::INTERNAL_ERROR;
};

const char* status_name(Ipopt::ApplicationReturnStatus s) {
  switch (s) {
    case Ipopt::Solve_Succeeded: return "Solve_Succeeded";
    case Ipopt::Solved_To_Acceptable_Level: return "Solved_To_Acceptable_Level";
    case Ipopt::Infeasible_Problem_Detected: return "Infeasible_Problem_Detected";
    case Ipopt::Search_Direction_Becomes_Too_Small: return "Search_Direction_Becomes_Too_Small";
    case Ipopt::Diverging_Iterates: return "Diverging_Iterates";
    case Ipopt::User_Requested_Stop: return "User_Requested_Stop";
    case Ipopt::Feasible_Point_Found: return "Feasible_Point_Found";
    case Ipopt::Maximum_Iterations_Exceeded: return "Maximum_Iterations_Exceeded";
    case Ipopt::Restoration_Failed: return "Restoration_Failed";
    case Ipopt::Error_In_Step_Computation: return "Error_In_Step_Computation";
    case Ipopt::Maximum_CpuTime_Exceeded: return "Maximum_CpuTime_Exceeded";
    case Ipopt::Not_Enough_Degrees_Of_Freedom: return "Not_Enough_Degrees_Of_Freedom";
    case Ipopt::Invalid_Problem_Definition: return "Invalid_Problem_Definition";
    case Ipopt::Invalid_Option: return "Invalid_Option";
    case Ipopt::Invalid_Number_Detected: return "Invalid_Number_Detected";
    case Ipopt::Unrecoverable_Exception: return "Unrecoverable_Exception";
    case Ipopt::NonIpopt_Exception_Thrown: return "NonIpopt_Exception_Thrown";
    case Ipopt::Insufficient_Memory: return "Insufficient_Memory";
    case Ipopt::Internal_Error: return "Internal_Error";
  }
  return "Unknown_Status";
}

}  // namespace

bool IpoptOptions::is_valid(std::string* error) const {
  std::ostringstream e;
  if (!(tol > 0) || !std::isfinite(tol)) {
    e << "tol = " << tol << " must be positive and finite";
  } else if (max_iterations < 0) {
    e << "max_iterations = " << max_iterations << " must be >= 0";
  } else if (print_level < 0 || print_level > 12) {
    e << "print_level = " << print_level << " must be in 0..12";
  } else if (threads < 1) {
    e << "threads = " << threads << " must be >= 1";
  } else if (linear_solver.empty()) {
    e << "linear_solver must not be empty";
  } else {
    return true;
  }
  if (error) *error = e.str();
  return false;
}

std::string IpoptResult::brief_report() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "IPOPT: %s after %d iterations, %.3f s; DEL residual %.3e (%s), action %.10g; %ld unknowns",
                status.c_str(), iterations, wall_seconds, residual, converged ? "converged" : "not converged",
                action, variables);
  std::string s = buf;
  if (!message.empty()) s += "; " + message;
  return s;
}

Trajectory straight_line(const Problem& problem) {
  Trajectory tr;
  if (!problem.model || problem.N < 1) return tr;
  const int d = problem.model->dim;
  tr.N = problem.N;
  tr.dim = d;
  tr.t.resize(static_cast<std::size_t>(problem.N) + 1);
  tr.q.resize(static_cast<std::size_t>(problem.N + 1) * d);
  for (int k = 0; k <= problem.N; ++k) {
    const double s = static_cast<double>(k) / problem.N;
    tr.t[static_cast<std::size_t>(k)] = problem.t0 + s * problem.T;
    for (int a = 0; a < d; ++a) {
      const double x0 = a < static_cast<int>(problem.q0.size()) ? problem.q0[static_cast<std::size_t>(a)] : 0.0;
      const double x1 = a < static_cast<int>(problem.qN.size()) ? problem.qN[static_cast<std::size_t>(a)] : 0.0;
      tr.node(k)[a] = (1 - s) * x0 + s * x1;
    }
  }
  return tr;
}

double del_residual(const Problem& problem, const Trajectory& trajectory) {
  Grid g;
  std::string error;
  if (!build_grid(problem, g, &error) || trajectory.q.size() != static_cast<std::size_t>(g.N + 1) * g.dim)
    return std::nan("");
  std::vector<double> Ld(static_cast<std::size_t>(g.N)), D1(Ld.size() * g.dim), D2(D1.size());
  eval_grad(g, trajectory.q.data(), 1, Ld, D1, D2);
  return residual_from(g, D1, D2);
}

double action_of(const Problem& problem, const Trajectory& trajectory) {
  Grid g;
  std::string error;
  if (!build_grid(problem, g, &error) || trajectory.q.size() != static_cast<std::size_t>(g.N + 1) * g.dim)
    return std::nan("");
  double s = 0;
  const int d = g.dim;
  for (int k = 0; k < g.N; ++k) {
    const double* q = trajectory.node(k);
    s += g.disc->action(g.h, g.t(k), g.t(k + 1), q, q + d, g.p());
  }
  return s;
}

IpoptResult solve_ipopt(const Problem& problem, const IpoptOptions& options, Trajectory& trajectory) {
  IpoptResult result;
  std::string error;
  if (!options.is_valid(&error)) {
    result.message = "invalid option: " + error;
    return result;
  }
  Grid g;
  if (!build_grid(problem, g, &error) || !pin_fixed(problem, g, trajectory, &error)) {
    result.message = "invalid problem: " + error;
    return result;
  }
  result.variables = g.nvars;

  Ipopt::SmartPtr<ActionNlp> nlp = new ActionNlp(g, trajectory.q, options.threads);
  result.hessian_nonzeros = nlp->nonzeros();
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
  app->Options()->SetIntegerValue("print_level", options.print_level);
  app->Options()->SetStringValue("sb", "yes");  // no banner
  app->Options()->SetStringValue("hessian_approximation", "exact");
  app->Options()->SetStringValue("linear_solver", options.linear_solver);
  // Unscaled objective: IPOPT's dual infeasibility is then the infinity-norm of the gradient,
  // which for this unconstrained problem is the DEL residual.
  app->Options()->SetStringValue("nlp_scaling_method", "none");
  app->Options()->SetNumericValue("tol", options.tol);
  app->Options()->SetNumericValue("dual_inf_tol", options.tol);
  app->Options()->SetIntegerValue("max_iter", options.max_iterations);
  if (!options.allow_acceptable) app->Options()->SetIntegerValue("acceptable_iter", 0);
  Ipopt::ApplicationReturnStatus status = app->Initialize();
  if (status != Ipopt::Solve_Succeeded) {
    result.status = status_name(status);
    result.message = "IPOPT failed to initialize";
    return result;
  }
  const auto start = std::chrono::steady_clock::now();
  status = app->OptimizeTNLP(Ipopt::SmartPtr<Ipopt::TNLP>(GetRawPtr(nlp)));
  result.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  result.ran = true;
  result.status = status_name(status);
  if (Ipopt::IsValid(app->Statistics())) result.iterations = app->Statistics()->IterationCount();
  result.residual = del_residual(problem, trajectory);
  result.action = action_of(problem, trajectory);
  result.converged = result.residual <= options.tol;
  return result;
}

}  // namespace pardel::peer
