/**
 * @file bench_suite.cpp
 * pardel-bench-suite: the whole-solve measurements behind docs/benchmarks.md, one CSV per
 * subcommand on stdout (tools/benchmarks/run_all.py runs them and draws the charts):
 *   peer        the seed's fuel-optimal example at several N: every pardel method and IPOPT
 *   scaling     time to solution and per iteration against N and threads
 *   memory      max RSS of one solve (run once per N, in a fresh process)
 *   workprec    per scene, each method x discretization x N: time to converge against the error
 *               w.r.t. a Richardson-extrapolated reference (nested Newton at ref-N and ref-N/2)
 *   stability   where each method converges, diverges or lands on another solution
 *   sweep-cpu   one Jacobi-Newton sweep against its kernels alone, in CPU time on one thread
 * Wall times come from the solver's Summary (setup of the problem excluded).
 */
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "pardel/pardel.hpp"
#include "pardel/app/scene.hpp"
#ifdef PARDEL_BENCH_WITH_IPOPT
#include "ipopt_peer.hpp"
#endif

namespace {

[[noreturn]] void fail(const std::string& message) {
  std::fprintf(stderr, "pardel-bench-suite: error: %s\n", message.c_str());
  std::exit(2);
}

/** --key value options after the subcommand. */
struct Args {
  std::map<std::string, std::string> kv;
  std::string get(const std::string& key, const std::string& fallback) const {
    auto it = kv.find(key);
    return it == kv.end() ? fallback : it->second;
  }
  double num(const std::string& key, double fallback) const {
    auto it = kv.find(key);
    if (it == kv.end()) return fallback;
    char* end = nullptr;
    const double v = std::strtod(it->second.c_str(), &end);
    if (*end != '\0' || !std::isfinite(v)) fail("--" + key + ": '" + it->second + "' is not a number");
    return v;
  }
  std::vector<double> list(const std::string& key, const std::string& fallback) const {
    const std::string text = get(key, fallback);
    std::vector<double> out;
    std::size_t start = 0;
    while (start <= text.size()) {
      const std::size_t comma = text.find(',', start);
      const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      char* end = nullptr;
      const double v = std::strtod(item.c_str(), &end);
      if (item.empty() || *end != '\0') fail("--" + key + ": '" + item + "' is not a number");
      out.push_back(v);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
    return out;
  }
  std::vector<std::string> words(const std::string& key, const std::string& fallback) const {
    const std::string text = get(key, fallback);
    std::vector<std::string> out;
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = text.find(',', start);
      out.push_back(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
    return out;
  }
};

const pardel_model* model_or_fail(const std::string& name) {
  const pardel_model* m = pardel::find_model(name);
  if (!m) fail("--model: '" + name + "' is not bundled in this build");
  return m;
}

const pardel_discretization* disc_or_fail(const pardel_model& m, const std::string& name) {
  if (name.empty()) return &m.discretizations[0];
  const pardel_discretization* d = pardel::find_discretization(m, name);
  if (!d) fail("--disc: model '" + std::string(m.name) + "' has no discretization '" + name + "'");
  return d;
}

/** The seed's fuel-optimal example: T = 30, (0,0) -> (6,5). */
pardel::Problem fuel_problem(int N, const std::string& disc = "trapezoid") {
  pardel::Problem p;
  p.model = model_or_fail("fuel_nav");
  p.discretization = disc_or_fail(*p.model, disc);
  p.T = 30;
  p.N = N;
  p.q0 = {0, 0};
  p.qN = {6, 5};
  return p;
}

bool parse_method_or_fail(const std::string& text, pardel::Method* m) {
  if (!pardel::parse_method(text, m)) fail("unknown method '" + text + "'");
  return true;
}

/**
 * Sets the method of `o` from a benchmark method name: a pardel method name, or "newton-nested":
 * newton with nested iteration from `nested_start` intervals, doubling N (plain newton when
 * N <= nested_start).
 */
void configure_method(const std::string& name, int N, int nested_start, pardel::Options& o) {
  if (name == "newton-nested") {
    o.method = pardel::Method::newton;
    if (N > nested_start) {
      o.refine_start_N = nested_start;
      o.refine_factor = 2;
    }
    return;
  }
  parse_method_or_fail(name, &o.method);
}

struct Run {
  pardel::Summary summary;
  double extrapolated_iterations = 0;  ///< for capped runs: iterations to reach tol at the last rate
  double extrapolated_seconds = 0;
  bool capped = false;
};

/** Solves with a wall-time cap; a capped run is extrapolated from its last convergence rate. */
Run solve_capped(const pardel::Problem& p, pardel::Options o, pardel::Trajectory& tr, double cap_seconds) {
  Run run;
  const auto start = std::chrono::steady_clock::now();
  bool stopped = false;
  o.on_iteration = [&](const pardel::IterationRecord&) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > cap_seconds) {
      stopped = true;
      return false;
    }
    return true;
  };
  run.summary = pardel::solve(p, o, tr);
  run.capped = stopped && run.summary.termination == pardel::Termination::interrupted;
  const auto& h = run.summary.history;
  if (run.capped && h.size() >= 4) {
    // Rate over the last quarter of the recorded history.
    const auto& b = h.back();
    const auto& a = h[h.size() * 3 / 4 - 1];
    if (b.iteration > a.iteration && a.residual > 0 && b.residual > 0 && b.residual < a.residual) {
      const double rate = std::pow(b.residual / a.residual, 1.0 / static_cast<double>(b.iteration - a.iteration));
      const double more = std::log(o.tol / b.residual) / std::log(rate);
      run.extrapolated_iterations = static_cast<double>(b.iteration) + std::max(0.0, more);
      run.extrapolated_seconds = run.summary.wall_seconds * run.extrapolated_iterations / b.iteration;
    } else {
      run.extrapolated_iterations = run.extrapolated_seconds = INFINITY;
    }
  }
  return run;
}

long max_rss_kib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

// ---------------------------------------------------------------------------------------------

int cmd_peer(const Args& a) {
  const std::vector<double> Ns = a.list("N", "200,2000,20000,200000");
  const std::vector<std::string> methods = a.words("methods", "newton,newton-nested,hybrid,jacobi-newton,ipopt");
  const double cap = a.num("cap", 60);
  const int threads = static_cast<int>(a.num("threads", 2));
  const int nested_start = static_cast<int>(a.num("nested-start", 200));
  const double tol = a.num("tol", 1e-10);
  std::printf("N,method,status,iterations,seconds,residual,action,extrapolated_iterations,extrapolated_seconds,"
              "message\n");
  for (double Nd : Ns) {
    const int N = static_cast<int>(Nd);
    const pardel::Problem p = fuel_problem(N);
    for (const std::string& name : methods) {
      if (name == "ipopt") {
#ifdef PARDEL_BENCH_WITH_IPOPT
        pardel::Trajectory tr = pardel::linear_guess(p);
        pardel::peer::IpoptOptions io;
        io.tol = tol;
        io.threads = 1;
        const pardel::peer::IpoptResult r = pardel::peer::solve_ipopt(p, io, tr);
        std::printf("%d,ipopt,%s,%d,%.6f,%.3e,%.12g,,,\n", N, r.status.c_str(), r.iterations, r.wall_seconds,
                    r.residual, r.action);
#else
        std::printf("%d,ipopt,not_built,,,,,,,IPOPT was not found at configure time\n", N);
#endif
        std::fflush(stdout);
        continue;
      }
      pardel::Options o;
      configure_method(name, N, nested_start, o);
      o.tol = tol;
      o.threads = threads;
      o.max_iterations = 100000000;
      o.history_every = o.method == pardel::Method::jacobi_newton ? 1000 : 1;
      pardel::Trajectory tr = pardel::linear_guess(p);
      const Run run = solve_capped(p, o, tr, cap);
      const pardel::Summary& s = run.summary;
      std::string msg = s.message;
      for (char& c : msg)
        if (c == ',' || c == '\n') c = ';';
      std::printf("%d,%s,%s,%ld,%.6f,%.3e,%.12g,", N, name.c_str(),
                  run.capped ? "time_cap" : pardel::to_string(s.termination), s.iterations, s.wall_seconds,
                  s.residual, s.action);
      if (run.capped)
        std::printf("%.0f,%.1f,", run.extrapolated_iterations, run.extrapolated_seconds);
      else
        std::printf(",,");
      std::printf("%s\n", msg.c_str());
      std::fflush(stdout);
    }
  }
  return 0;
}

int cmd_scaling(const Args& a) {
  const std::vector<double> Ns = a.list("N", "100,1000,10000,100000,1000000");
  const std::vector<std::string> methods = a.words("methods", "newton-nested,newton");
  const std::vector<double> threads_list = a.list("threads", "1,2");
  const int nested_start = static_cast<int>(a.num("nested-start", 200));
  const double cap = a.num("cap", 60);
  const double tol = a.num("tol", 1e-10);
  std::printf("N,method,threads,status,iterations,seconds,seconds_per_iteration,residual,action,load\n");
  for (double Nd : Ns) {
    const int N = static_cast<int>(Nd);
    const pardel::Problem p = fuel_problem(N);
    for (const std::string& name : methods) {
      for (double th : threads_list) {
        pardel::Options o;
        configure_method(name, N, nested_start, o);
        o.tol = tol;
        o.threads = static_cast<int>(th);
        o.max_iterations = 100000000;
        o.history_every = 1000;
        pardel::Trajectory tr = pardel::linear_guess(p);
        const Run run = solve_capped(p, o, tr, cap);
        const pardel::Summary& s = run.summary;
        double load[1] = {0};
        getloadavg(load, 1);
        std::printf("%d,%s,%d,%s,%ld,%.6f,%.6e,%.3e,%.12g,%.2f\n", N, name.c_str(), o.threads,
                    run.capped ? "time_cap" : pardel::to_string(s.termination), s.iterations, s.wall_seconds,
                    s.iterations > 0 ? s.wall_seconds / s.iterations : 0.0, s.residual, s.action, load[0]);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

int cmd_memory(const Args& a) {
  const int N = static_cast<int>(a.num("N", 1e7));
  pardel::Options o;
  parse_method_or_fail(a.get("method", "jacobi-newton"), &o.method);
  o.max_iterations = static_cast<long>(a.num("iterations", 5));
  o.threads = static_cast<int>(a.num("threads", 2));
  const long before = max_rss_kib();
  const pardel::Problem p = fuel_problem(N);
  pardel::Trajectory tr = pardel::linear_guess(p);
  const long with_guess = max_rss_kib();
  const pardel::Summary s = pardel::solve(p, o, tr);
  const long after = max_rss_kib();
  std::printf("N,method,iterations,rss_start_kib,rss_guess_kib,rss_max_kib,bytes_per_node_total,"
              "bytes_per_node_solver\n");
  std::printf("%d,%s,%ld,%ld,%ld,%ld,%.1f,%.1f\n", N, pardel::to_string(o.method), s.iterations, before, with_guess,
              after, 1024.0 * (after - before) / (N + 1), 1024.0 * (after - with_guess) / (N + 1));
  return 0;
}

/** CPU seconds of this process (a one-thread measurement that other processes on the machine
 *  disturb far less than wall time). */
double cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

/** One Jacobi-Newton sweep against the sweep kernel alone on every interval, in CPU time on one
 *  thread: the minimum over repetitions of (solve with 2 + n sweeps - solve with 2 sweeps) / n. */
int cmd_sweep_cpu(const Args& a) {
  const std::vector<double> Ns = a.list("N", "1000,100000,1000000");
  const int repeat = static_cast<int>(a.num("repeat", 7));
  std::printf("N,sweeps,kernels_seconds,sweep_seconds,sweep_over_kernels,node_updates_per_s\n");
  for (double Nd : Ns) {
    const int N = static_cast<int>(Nd);
    const long n = std::max(2L, static_cast<long>(4e6 / N));
    const pardel::Problem p = fuel_problem(N);
    const pardel::Trajectory guess = pardel::linear_guess(p);
    const int d = p.model->dim;
    const std::size_t dd = static_cast<std::size_t>(d) * d;
    std::vector<double> D1(static_cast<std::size_t>(N) * d), D2(D1.size()), D11(N * dd), D22(N * dd);
    const double h = p.T / N;
    auto sweeps = [&](long count) {
      pardel::Options o;
      o.method = pardel::Method::jacobi_newton;
      o.threads = 1;
      o.max_iterations = count;
      o.history_every = 1L << 40;
      pardel::Trajectory tr = guess;
      const double c0 = cpu_seconds();
      pardel::solve(p, o, tr);
      return cpu_seconds() - c0;
    };
    double kernels = INFINITY, sweep = INFINITY;
    for (int r = 0; r < repeat; ++r) {
      const double c0 = cpu_seconds();
      for (long it = 0; it < n; ++it)
        for (int k = 0; k < N; ++k) {
          const std::size_t kk = static_cast<std::size_t>(k);
          p.discretization->sweep(h, k * h, (k + 1) * h, guess.node(k), guess.node(k + 1), nullptr, &D1[kk * d],
                                  &D2[kk * d], &D11[kk * dd], &D22[kk * dd]);
        }
      kernels = std::min(kernels, (cpu_seconds() - c0) / n);
      const double few = sweeps(2), many = sweeps(2 + n);
      sweep = std::min(sweep, (many - few) / n);
    }
    std::printf("%d,%ld,%.6e,%.6e,%.3f,%.4e\n", N, n, kernels, sweep, sweep / kernels, (N - 1) / sweep);
    std::fflush(stdout);
  }
  return 0;
}

/** Max |a(t) - b(t)| over the coordinates at the nodes of the coarser trajectory (a), which are nodes of b. */
double max_error_shared(const pardel::Trajectory& coarse, const pardel::Trajectory& fine, int ncoords) {
  const int ratio = fine.N / coarse.N;
  double e = 0;
  for (int k = 0; k <= coarse.N; ++k)
    for (int i = 0; i < ncoords; ++i)
      e = std::max(e, std::fabs(coarse.node(k)[i] - fine.node(k * ratio)[i]));
  return e;
}

/** A scene file with `--set`-style overrides (models resolved among the bundled ones). */
pardel::app::Scene load_or_fail(const std::string& path, const std::vector<std::string>& sets) {
  try {
    return pardel::app::load_scene(path, sets, [](const std::string& name) { return pardel::find_model(name); });
  } catch (const std::exception& e) {
    fail(e.what());
  }
}
pardel::app::Scene scene_as_written(const std::string& path) { return load_or_fail(path, {}); }
/** The scene at another grid size and discretization. */
pardel::app::Scene scene_at(const std::string& path, int N, const std::string& disc) {
  return load_or_fail(path, {"grid.N=" + std::to_string(N), "discretization=" + disc});
}

/**
 * The scene's tolerance at N: as written for N <= the scene's own N0; for order-2 models, whose
 * attainable residual grows like N^3 (docs/solvers.md, statuses), scaled by (N / N0)^3 above it.
 */
double tol_at(const pardel::app::Scene& base, int N) {
  const double tol = base.options.tol;
  if (base.problem.model->order < 2 || N <= base.problem.N) return tol;
  return tol * std::pow(static_cast<double>(N) / base.problem.N, 3);
}

/** Options for a work-precision run: the scene's (clock, tolerance) with the benchmark's method. */
pardel::Options workprec_options(const pardel::app::Scene& base, const std::string& method, int N, int threads) {
  pardel::Options o = base.options;
  o.refine_start_N = 0;
  configure_method(method, N, base.problem.N, o);
  o.tol = tol_at(base, N);
  o.threads = threads;
  o.max_iterations = 100000000;
  o.history_every = 1000;
  return o;
}

int cmd_workprec(const Args& a) {
  const std::string path = a.get("scene", "scenes/fuel_nav.toml");
  const pardel::app::Scene base = scene_as_written(path);
  const std::string name = std::filesystem::path(path).stem().string();
  const std::vector<std::string> methods = a.words("methods", "newton,newton-nested,hybrid,jacobi-newton");
  const std::vector<double> Ns = a.list("N", "50,100,200,400");
  const int threads = static_cast<int>(a.num("threads", 1));
  const double cap = a.num("cap", 2);
  const int ref_N = static_cast<int>(a.num("ref-N", 3200));
  const double ref_cap = a.num("ref-cap", 60);
  const pardel_model* m = base.problem.model;
  std::printf("scene,discretization,method,N,status,iterations,seconds,residual,tol,action,action_error,max_error\n");
  for (int di = 0; di < m->ndiscretizations; ++di) {
    const std::string disc = m->discretizations[di].name;
    // Reference: nested Newton at ref_N/2 and ref_N, Richardson-extrapolated at the nodes of ref_N/2.
    pardel::Trajectory fine, coarse;
    pardel::Summary sf, sc;
    for (int half = 0; half < 2; ++half) {
      const int n = half ? ref_N / 2 : ref_N;
      const pardel::app::Scene sn = scene_at(path, n, disc);
      pardel::Options ro = workprec_options(base, "newton-nested", n, threads);
      pardel::Trajectory tr = pardel::app::make_initial_guess(sn);
      pardel::Summary s = solve_capped(sn.problem, ro, tr, ref_cap).summary;
      (half ? coarse : fine) = tr;
      (half ? sc : sf) = s;
    }
    if (!sf.converged() || !sc.converged()) {
      std::fprintf(stderr, "reference for %s/%s did not converge: %s | %s\n", name.c_str(), disc.c_str(),
                   sf.brief_report().c_str(), sc.brief_report().c_str());
      continue;
    }
    const double w = std::pow(2.0, m->discretizations[di].consistency_order);
    const double action_ref = (w * sf.action - sc.action) / (w - 1);
    pardel::Trajectory ref = coarse;
    for (int k = 0; k <= coarse.N; ++k)
      for (int i = 0; i < m->dim; ++i) ref.node(k)[i] = (w * fine.node(2 * k)[i] - coarse.node(k)[i]) / (w - 1);
    std::fprintf(stderr, "%s/%s: reference action %.15g (N = %d: %.15g in %.2f s, N = %d: %.15g in %.2f s)\n",
                 name.c_str(), disc.c_str(), action_ref, ref_N, sf.action, sf.wall_seconds, ref_N / 2, sc.action,
                 sc.wall_seconds);
    for (double Nd : Ns) {
      const int N = static_cast<int>(Nd);
      if ((ref_N / 2) % N != 0) fail("--N: " + std::to_string(N) + " does not divide ref-N/2");
      const pardel::app::Scene sn = scene_at(path, N, disc);
      for (const std::string& method : methods) {
        const pardel::Options o = workprec_options(base, method, N, threads);
        pardel::Trajectory tr = pardel::app::make_initial_guess(sn);
        const Run run = solve_capped(sn.problem, o, tr, cap);
        const pardel::Summary& s = run.summary;
        const bool finite = std::isfinite(s.action) && tr.N == N;
        std::printf("%s,%s,%s,%d,%s,%ld,%.6e,%.3e,%.3e,%.15g,%.3e,%.3e\n", name.c_str(), disc.c_str(), method.c_str(), N,
                    run.capped ? "time_cap" : pardel::to_string(s.termination), s.iterations, s.wall_seconds,
                    s.residual, o.tol, s.action, finite ? std::fabs(s.action - action_ref) : NAN,
                    finite ? max_error_shared(tr, ref, m->ncoords) : NAN);
        std::fflush(stdout);
      }
    }
  }
  return 0;
}

/** Outcome classes of the stability maps. */
enum Outcome { reference = 0, other_solution = 1, no_convergence = 2, diverged = 3 };

int classify(const pardel::Summary& s, const pardel::Trajectory& tr, const std::vector<double>& ref, double tol) {
  if (!s.converged()) {
    if (s.termination == pardel::Termination::max_iterations || s.termination == pardel::Termination::interrupted)
      return no_convergence;
    return diverged;
  }
  if (ref.empty()) return other_solution;
  double e = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) e = std::max(e, std::fabs(tr.q[i] - ref[i]));
  return e <= tol ? reference : other_solution;
}

/** The unique solution of a linear scalar DEL system (one Newton step solves it exactly): the
 *  tridiagonal system from the full kernel at the straight line, by the Thomas algorithm. Empty
 *  when a pivot vanishes (a conjugate point). */
std::vector<double> linear_scalar_solution(const pardel::Problem& p) {
  const int N = p.N;
  const double h = p.T / N;
  pardel::Trajectory tr = pardel::linear_guess(p);
  std::vector<double> d(N + 1), c(N + 1), r(N + 1);
  std::vector<double> D1(N), D2(N), D11(N), D12(N), D22(N);
  const double* par = p.params.empty() ? p.model->param_defaults : p.params.data();
  for (int k = 0; k < N; ++k) {
    double Ld;
    p.discretization->full(h, p.t0 + k * h, p.t0 + (k + 1) * h, tr.node(k), tr.node(k + 1), par, &Ld, &D1[k], &D2[k],
                           &D11[k], &D12[k], &D22[k]);
  }
  // H dq = -res over nodes 1..N-1: diag D22(k-1)+D11(k), off D12(k).
  std::vector<double> cp(N + 1), dp(N + 1);
  for (int k = 1; k < N; ++k) {
    const double diag = D22[k - 1] + D11[k];
    const double rhs = -(D2[k - 1] + D1[k]);
    const double lower = k > 1 ? D12[k - 1] : 0;
    const double denom = diag - lower * cp[k - 1];
    if (std::fabs(denom) < 1e-300) return {};
    cp[k] = k + 1 < N ? D12[k] / denom : 0;
    dp[k] = (rhs - lower * dp[k - 1]) / denom;
  }
  std::vector<double> dq(N + 1, 0.0);
  for (int k = N - 1; k >= 1; --k) dq[k] = dp[k] - cp[k] * (k + 1 < N ? dq[k + 1] : 0);
  std::vector<double> out(N + 1);
  for (int k = 0; k <= N; ++k) out[k] = tr.node(k)[0] + dq[k];
  return out;
}

int cmd_stability(const Args& a) {
  const std::string which = a.get("map", "harmonic");
  const std::vector<std::string> methods = a.words("methods", "jacobi-newton,newton,hybrid");
  const long max_it = static_cast<long>(a.num("max-iterations", 20000));
  const double cap = a.num("cap", 2);
  auto run_one = [&](const pardel::Problem& p, const std::string& name, double damping, pardel::Trajectory& tr) {
    pardel::Options o;
    parse_method_or_fail(name, &o.method);
    o.tol = 1e-10;
    o.threads = 1;
    o.damping = damping;
    o.max_iterations = o.method == pardel::Method::newton ? 500 : max_it;  // hybrid starts with sweeps
    o.history_every = 1000;
    tr = pardel::linear_guess(p);
    return solve_capped(p, o, tr, cap).summary;
  };
  if (which == "harmonic") {
    // Over (omega h, omega T) with T = 1: x(0) = 0, x(1) = 1; the first conjugate point is omega T = pi.
    std::printf("map,method,x,y,N,outcome,iterations\n");
    const pardel_model* m = model_or_fail("harmonic");
    for (double wT = 0.25; wT <= 6.01; wT += 0.25) {
      for (double wh : {0.02, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0, 1.4, 1.8, 2.2, 2.6}) {
        const int N = std::max(2, static_cast<int>(std::lround(wT / wh)));
        pardel::Problem p;
        p.model = m;
        p.discretization = disc_or_fail(*m, "trapezoid");
        p.params = {wT};
        p.T = 1;
        p.N = N;
        p.q0 = {0};
        p.qN = {1};
        const std::vector<double> ref = linear_scalar_solution(p);
        for (const std::string& name : methods) {
          pardel::Trajectory tr;
          const pardel::Summary s = run_one(p, name, 0, tr);
          std::printf("harmonic,%s,%.4f,%.4f,%d,%d,%ld\n", name.c_str(), wT / N, wT, N,
                      classify(s, tr, ref, 1e-6 * (1 + std::fabs(*std::max_element(ref.begin(), ref.end())))),
                      s.iterations);
        }
        std::fflush(stdout);
      }
    }
  } else if (which == "bratu") {
    // Over lambda (across lambda_c = 3.5138) and N; reference: the closed-form lower solution.
    std::printf("map,method,x,y,N,outcome,iterations\n");
    const pardel_model* m = model_or_fail("bratu");
    for (double lambda = 0.25; lambda <= 5.01; lambda += 0.25) {
      double th = 1;
      bool have = lambda < 3.5138;
      for (int i = 0; have && i < 500; ++i) th = std::sqrt(2 * lambda) * std::cosh(th / 4);
      for (int N : {8, 16, 32, 64, 128, 256}) {
        pardel::Problem p;
        p.model = m;
        p.discretization = disc_or_fail(*m, "trapezoid");
        p.params = {lambda};
        p.T = 1;
        p.N = N;
        p.q0 = {0};
        p.qN = {0};
        std::vector<double> ref;
        if (have && std::isfinite(th))
          for (int k = 0; k <= N; ++k) {
            const double t = static_cast<double>(k) / N;
            ref.push_back(-2 * std::log(std::cosh((t - 0.5) * th / 2) / std::cosh(th / 4)));
          }
        for (const std::string& name : methods) {
          pardel::Trajectory tr;
          const pardel::Summary s = run_one(p, name, 0, tr);
          // The discrete solution is within O(h^2) of the continuous one.
          std::printf("bratu,%s,%.4f,%d,%d,%d,%ld\n", name.c_str(), lambda, N, N,
                      classify(s, tr, ref, 2.0 / (N * N)), s.iterations);
        }
        std::fflush(stdout);
      }
    }
  } else if (which == "fuel") {
    // Over damping epsilon and N; reference: Newton's answer at that N.
    std::printf("map,method,x,y,N,outcome,iterations\n");
    for (int N : {10, 20, 40, 80, 160}) {
      const pardel::Problem p = fuel_problem(N);
      pardel::Trajectory nt;
      const pardel::Summary sn = run_one(p, "newton", 0, nt);
      const std::vector<double> ref = sn.converged() ? nt.q : std::vector<double>{};
      for (double eps : {0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9}) {
        for (const std::string& name : methods) {
          if (name == "newton" && eps > 0) continue;  // Newton has no damping
          pardel::Trajectory tr;
          const pardel::Summary s = run_one(p, name, eps, tr);
          std::printf("fuel,%s,%.2f,%d,%d,%d,%ld\n", name.c_str(), eps, N, N, classify(s, tr, ref, 1e-7),
                      s.iterations);
        }
        std::fflush(stdout);
      }
    }
  } else {
    fail("--map: '" + which + "' is not one of harmonic, bratu, fuel");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help")) {
    std::printf(
        "usage: pardel-bench-suite COMMAND [--key value ...]\n"
        "  peer       [--N 200,2000,...] [--methods newton,...,ipopt] [--cap 60] [--threads 2] [--tol 1e-10]\n"
        "  scaling    [--N ...] [--methods ...] [--threads 1,2] [--cap 60]\n"
        "  memory     [--N 1e7] [--method jacobi-newton] [--iterations 5] [--threads 2]\n"
        "  workprec   [--scene scenes/X.toml] [--N ...] [--ref-N 3200] [--methods ...] [--cap 2] [--ref-cap 60] [--threads 1]\n"
        "  stability  [--map harmonic|bratu|fuel] [--methods ...] [--max-iterations 20000] [--cap 2]\n"
        "  sweep-cpu  [--N 1000,100000,1000000] [--repeat 7]   (one thread, CPU time)\n");
    return argc < 2 ? 2 : 0;
  }
  Args args;
  for (int i = 2; i < argc; ++i) {
    const std::string key = argv[i];
    if (key.rfind("--", 0) != 0 || i + 1 >= argc) fail("expected --key value, got '" + key + "'");
    args.kv[key.substr(2)] = argv[++i];
  }
  const std::string cmd = argv[1];
  if (cmd == "peer") return cmd_peer(args);
  if (cmd == "scaling") return cmd_scaling(args);
  if (cmd == "memory") return cmd_memory(args);
  if (cmd == "workprec") return cmd_workprec(args);
  if (cmd == "sweep-cpu") return cmd_sweep_cpu(args);
  if (cmd == "stability") return cmd_stability(args);
  fail("unknown command '" + cmd + "'");
}
