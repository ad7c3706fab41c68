/**
 * @file cuda.cu
 * The host side of solve_batch_cuda (pardel/cuda.hpp): what the device takes and refuses, the
 * batch as flat arrays, the memory check before anything is allocated on the device, and the
 * entries made from the device's per-problem records (messages, actions, point assessments).
 */
#include <cuda_runtime.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "batch_entries.hpp"
#include "batch_newton.hpp"
#include "device_registry.hpp"
#include "engine.hpp"
#include "trust_region.hpp"
#include "pardel/cuda.hpp"

namespace pardel {
namespace cuda_detail {

void add_entry(std::vector<DeviceEntry>& entries, const pardel_model& model, pardel_sweep_kernel sweep,
               DeviceRunner run, DeviceRunner run_newton) {
  for (int i = 0; i < model.ndiscretizations; ++i)
    if (model.discretizations[i].sweep == sweep)
      entries.push_back({&model, &model.discretizations[i], run, run_newton});
}

}  // namespace cuda_detail

namespace {

namespace bs = pardel::batch_sweep;
using cuda_detail::DeviceEntry;

std::string format(const char* fmt, double a, double b = 0, double c = 0, double d = 0) {
  char buf[400];
  std::snprintf(buf, sizeof buf, fmt, a, b, c, d);
  return buf;
}

bool same_text(const char* a, const char* b) { return (a == nullptr) == (b == nullptr) && (!a || std::strcmp(a, b) == 0); }

/** Whether two sweep kernels of a model give the same values (to 1e-12 relative, NaN as NaN) at a
 *  few points of no pattern: the device's copy and the program's host build of one generated
 *  source do, up to rounding; another model of the same name does not. */
bool same_sweep(pardel_sweep_kernel f, pardel_sweep_kernel g, const pardel_model& m) {
  const std::size_t d = static_cast<std::size_t>(m.dim);
  std::vector<double> q0(d), q1(d), p(m.param_defaults, m.param_defaults + m.nparams), a(2 * d + 2 * d * d),
      b(a.size());
  for (int point = 0; point < 3; ++point) {
    for (std::size_t i = 0; i < d; ++i) {
      q0[i] = 0.13 + 0.37 * static_cast<double>(i) - 0.29 * point;
      q1[i] = q0[i] + 0.07 + 0.05 * std::sin(1.7 * static_cast<double>(i) + point);
    }
    const double h = 0.11 + 0.03 * point, t0 = 0.2 * point;
    f(h, t0, t0 + h, q0.data(), q1.data(), p.data(), a.data(), a.data() + d, a.data() + 2 * d, a.data() + 2 * d + d * d);
    g(h, t0, t0 + h, q0.data(), q1.data(), p.data(), b.data(), b.data() + d, b.data() + 2 * d, b.data() + 2 * d + d * d);
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (std::isnan(a[i]) && std::isnan(b[i])) continue;
      if (!(std::fabs(a[i] - b[i]) <= 1e-12 * std::max(1.0, std::fabs(a[i])))) return false;
    }
  }
  return true;
}

/** The device's entry for this model and discretization: the device copy of the same generated
 *  model (the same name, source file, sizes, coordinate and param names, discretization name and
 *  sweep kernel values), so that a model loaded at run time whose name is a bundled model's is
 *  not solved with the bundled kernels. */
const DeviceEntry* find_entry(const pardel_model& model, const pardel_discretization& disc) {
  for (const DeviceEntry& e : cuda_detail::device_entries()) {
    if (e.discretization == &disc) return &e;
    const pardel_model& m = *e.model;
    bool same = std::strcmp(m.name, model.name) == 0 && same_text(m.source, model.source) && m.order == model.order &&
                m.ncoords == model.ncoords && m.dim == model.dim && m.nparams == model.nparams &&
                m.time_dependent == model.time_dependent && std::strcmp(e.discretization->name, disc.name) == 0 &&
                disc.sweep != nullptr && e.discretization->sweep != nullptr;
    for (int i = 0; same && i < model.ncoords; ++i) same = same_text(m.coords[i], model.coords[i]);
    for (int i = 0; same && i < model.nparams; ++i)
      same = same_text(m.param_names[i], model.param_names[i]) && m.param_defaults[i] == model.param_defaults[i];
    if (same && same_sweep(e.discretization->sweep, disc.sweep, model)) return &e;
  }
  return nullptr;
}

std::string device_list() {
  std::string list;
  for (const DeviceEntry& e : cuda_detail::device_entries())
    list += (list.empty() ? "" : ", ") + std::string(e.model->name) + " (" + e.discretization->name + ")";
  return list.empty() ? std::string("none") : list;
}

/** Whether the device has this method: the sweeps, and Newton (auto is Newton there, on one grid). */
bool on_device(Method m) {
  return m == Method::jacobi || m == Method::jacobi_newton || m == Method::newton || m == Method::automatic;
}
bool newton_on_device(Method m) { return m == Method::newton || m == Method::automatic; }

/** Why the device does not take these options or this base problem ("" when it does). */
std::string options_refusal(const Problem& base, const Options& options) {
  std::string error;
  if (!options.is_valid(&error)) return error;
  if (!on_device(options.method))
    return std::string("the device solves with methods jacobi, jacobi-newton, newton and auto (newton on one grid); "
                       "method ") +
           to_string(options.method) + " runs on the CPU (solver.device = \"cpu\")";
  if (options.resume_from) return "solve_batch_cuda does not resume solves (Options::resume_from is set)";
  if (options.refine_start_N > 0) return "the device solves on one grid: refine_start_N must be 0";
  if (options.accuracy > 0) return "the device solves on one grid: accuracy (adaptive grids) must be 0";
  if (!base.model || !base.discretization) return "the base problem has no model or discretization";
  if (base.N < 2) return "the base problem needs N >= 2";
  if (!base.knots.empty()) return "the device batch takes no knots (solve_batch solves problems with knots)";
  if (base.clock != ClockMode::none) return "the device batch takes no clock (solve_batch solves problems with one)";
  return "";
}

Termination to_termination(int status) {
  switch (status) {
    case bs::converged: return Termination::converged;
    case bs::max_iterations: return Termination::max_iterations;
    case bs::diverged: return Termination::diverged;
    case bs::stalled: return Termination::stalled;
    case bs::running: return Termination::interrupted;
    default: return Termination::non_finite;
  }
}

/** The entry's message, in the words of the CPU solver where the rule is the same. */
std::string record_message(const cuda_detail::ProblemRecord& r, const Options& options, const pardel_model& model) {
  std::string unresolved;
  if (r.unresolved >= 0) {
    const std::size_t i = static_cast<std::size_t>(r.unresolved);
    const int nc = model.ncoords > 0 ? model.ncoords : 1;
    std::string name = model.coords ? model.coords[r.unresolved % nc] : std::to_string(r.unresolved);
    for (int d = 0; d < r.unresolved / nc; ++d) name += "'";
    unresolved = "; component " + name +
                 format("'s equations are resolved only to %.3g, above its own target %.3g: the solve is not converged",
                        r.comp_residual[i], r.comp_target[i]);
  }
  switch (r.status) {
    case bs::converged:
      return options.tol > 0 ? format("DEL residual %.3g <= tol %.3g", r.residual, r.target)
                             : format("DEL residual %.3g <= %.3g = max(rtol x scale of the DEL terms %.3g, 10 x "
                                      "round-off level)",
                                      r.residual, r.target, r.scale);
    case bs::max_iterations:
      return format("reached max_iterations = %.0f with DEL residual %.3g (tol %.3g)",
                    static_cast<double>(options.max_iterations), r.residual, r.target) +
             (r.residual <= r.target ? unresolved : std::string());
    case bs::stalled:
      if (r.reason == batch_newton::no_descent)  // the CPU solver's words for the same stop
        return detail::newton_stalled(r.iterations + 1, r.residual, 16 * 2.220446049250313e-16 * r.scale).message +
               unresolved;
      return format("stalled: the DEL residual %.3g is at the round-off level %.3g of this problem and no component "
                    "has come 1%% closer to its own target in 200 iterations",
                    r.residual, 16 * 2.220446049250313e-16 * r.scale) +
             unresolved;
    case bs::diverged:
      return r.residual > options.divergence_factor * r.r_initial
                 ? format("DEL residual %.3g grew beyond divergence_factor x initial residual %.3g at iteration %.0f",
                          r.residual, r.r_initial, static_cast<double>(r.iterations))
                 : format("iterates exploded (max |q| > 1e150) in iteration %.0f", static_cast<double>(r.iterations + 1));
    case bs::running:
      return format("interrupted by keep_going at iteration %.0f", static_cast<double>(r.iterations));
    default:
      if (r.reason == batch_newton::no_definite_shift)
        return format("newton: no shift made the Hessian of the action positive definite in iteration %.0f (its "
                      "entries are not finite); the last finite iterate is returned",
                      static_cast<double>(r.iterations + 1));
      if (r.reason == batch_newton::domain_edge)
        return "newton: in iteration " + std::to_string(r.iterations + 1) +
               " trial steps, down to a vanishing radius, give either no decrease of the action or a non-finite DEL "
               "residual or action" +
               (r.node >= 0 ? " (first at node " + std::to_string(r.node) + ")" : std::string()) +
               "; the last finite iterate is returned";
      return r.node >= 0 ? "non-finite DEL residual, value or singular diagonal block at node " +
                               std::to_string(r.node) + format(" (iteration %.0f); the last finite iterate is returned",
                                                               static_cast<double>(r.iterations))
                         : std::string("non-finite value");
  }
}

}  // namespace

void enable_cuda() {
  detail::set_device_batch_solver(Device::cuda, [](const Problem& base, const Options& options,
                                                   const std::vector<BatchProblem>& problems) {
    return solve_batch_cuda(base, options, problems);
  });
}

bool cuda_device_available(std::string* why) {
  int devices = 0;
  const cudaError_t status = cudaGetDeviceCount(&devices);
  if (status == cudaSuccess && devices > 0) return true;
  if (why) *why = status != cudaSuccess ? std::string("no CUDA device: ") + cudaGetErrorString(status) : "no CUDA device";
  return false;
}

bool cuda_supports(const pardel_model& model, const pardel_discretization& discretization, std::string* why) {
  if (find_entry(model, discretization)) return true;
  if (why) {
    bool namesake = false;
    for (const DeviceEntry& e : cuda_detail::device_entries()) namesake = namesake || std::strcmp(e.model->name, model.name) == 0;
    *why = std::string("model ") + model.name + " with discretization " + discretization.name +
           " is not compiled for the device" +
           (namesake ? std::string(" (this one is generated from ") + (model.source ? model.source : "an unnamed source") +
                           "; the device's model of that name is another)"
                     : std::string()) +
           "; the device build has: " + device_list() +
           " (PARDEL_DEVICE_MODELS at configure time, and models added with pardel_add_model(... DEVICE))";
  }
  return false;
}

namespace {

/** Why the device cannot solve this batch ("" when it can), and its entry of the device registry. */
std::string batch_refusal(const Problem& base, const Options& options, const CudaSettings& settings,
                          const DeviceEntry** entry) {
  std::string refusal = options_refusal(base, options);
  if (refusal.empty() && settings.check_every < 1) refusal = "CudaSettings::check_every must be >= 1";
  if (refusal.empty() && settings.blocks_per_problem < 0)
    refusal = "CudaSettings::blocks_per_problem must be >= 0 (0: chosen to fill the device)";
  if (refusal.empty() && !(*entry = find_entry(*base.model, *base.discretization)))
    cuda_supports(*base.model, *base.discretization, &refusal);
  std::string why;
  if (refusal.empty() && !cuda_device_available(&why)) refusal = why;
  return refusal;
}

/** Each problem's guess (with its end points) into q and its params into p, B problems of
 *  (N + 1) * dim values and nparams values each; a problem that fails validate() gets its
 *  invalid_input summary in `batch` and invalid[b] = 1 instead. */
void pack_problems(const Problem& base, const std::vector<BatchProblem>& problems, BatchSummary& batch,
                   std::vector<double>& q, std::vector<double>& p, std::vector<int>& invalid) {
  const pardel_model& model = *base.model;
  const int B = static_cast<int>(problems.size()), N = base.N, dim = model.dim, np = model.nparams;
  const std::size_t per = (static_cast<std::size_t>(N) + 1) * static_cast<std::size_t>(dim);
  for (int b = 0; b < B; ++b) {
    const BatchProblem& bp = problems[static_cast<std::size_t>(b)];
    BatchEntry& e = batch.entries[static_cast<std::size_t>(b)];
    const Problem problem = detail::entry_problem(base, bp);
    Trajectory guess = detail::entry_guess(problem, bp);
    std::string error;
    if (!validate(problem, guess, &error)) {
      e.summary.termination = Termination::invalid_input;
      e.summary.message = error;
      invalid[static_cast<std::size_t>(b)] = 1;
      continue;
    }
    if (guess.N != N) guess = resample(problem, guess, N);  // as solve() takes a guess on another grid
    std::copy(guess.q.begin(), guess.q.end(), q.begin() + static_cast<long>(b * per));
    std::copy(problem.q0.begin(), problem.q0.end(), q.begin() + static_cast<long>(b * per));
    std::copy(problem.qN.begin(), problem.qN.end(), q.begin() + static_cast<long>(b * per + N * dim));
    if (np > 0) {
      if (problem.params.empty())
        std::copy(model.param_defaults, model.param_defaults + np, p.begin() + static_cast<long>(b) * np);
      else
        std::copy(problem.params.begin(), problem.params.end(), p.begin() + static_cast<long>(b) * np);
    }
  }
}

/** The node times t (N + 1) and steps h (N) of the batch's grid, as the CPU solver makes them
 *  (runtime/src/engine.cpp). */
void batch_grid(const Problem& base, std::vector<double>& t, std::vector<double>& h) {
  const int N = base.N;
  std::fill(h.begin(), h.end(), base.T / N);
  for (int k = 0; k <= N; ++k) t[static_cast<std::size_t>(k)] = base.t0 + base.T * k / N;
  t[static_cast<std::size_t>(N)] = base.t0 + base.T;
  if (!base.times.empty()) {
    t = base.times;
    for (int k = 0; k < N; ++k) h[static_cast<std::size_t>(k)] = t[static_cast<std::size_t>(k) + 1] - t[static_cast<std::size_t>(k)];
  }
}

}  // namespace

BatchSummary solve_batch_cuda(const Problem& base, const Options& options, const std::vector<BatchProblem>& problems,
                              const CudaSettings& settings, CudaBatchTimes* times) {
  const auto start = std::chrono::steady_clock::now();
  BatchSummary batch;
  batch.threads = 1;
  const DeviceEntry* entry = nullptr;
  batch.refusal = batch_refusal(base, options, settings, &entry);
  if (!batch.refusal.empty()) return batch;

  const pardel_model& model = *base.model;
  const int B = static_cast<int>(problems.size()), N = base.N, dim = model.dim, np = model.nparams;
  const std::size_t nodes = static_cast<std::size_t>(N) + 1, per = nodes * static_cast<std::size_t>(dim);
  // Memory: the two iterate buffers (the sweeps), or the guesses and Newton's arrays, and the
  // per-problem records on the device, against what it has free, before anything is allocated
  // there or on the host.
  const bool newton = newton_on_device(options.method);
  const double per_problem = newton ? (static_cast<double>(per) + static_cast<double>(nodes) * (4 * dim + 3 * dim * dim)) * 8
                                    : 2.0 * per * 8;
  const double device_bytes = B * per_problem + B * (np * 8.0 + 1024) + nodes * 16.0;
  std::size_t free_bytes = 0, total_bytes = 0;
  if (cudaMemGetInfo(&free_bytes, &total_bytes) != cudaSuccess || device_bytes > 0.9 * free_bytes) {
    batch.refusal = format("a batch of %.0f problems needs about %.3g GB on the device, which has %.3g GB free", B,
                           device_bytes / 1e9, free_bytes / 1e9);
    return batch;
  }

  batch.entries.resize(problems.size());
  std::vector<double> q(static_cast<std::size_t>(B) * per), p(static_cast<std::size_t>(B) * np);
  std::vector<int> invalid(static_cast<std::size_t>(B), 0);
  pack_problems(base, problems, batch, q, p, invalid);
  std::vector<double> t(nodes), h(static_cast<std::size_t>(N));
  batch_grid(base, t, h);

  cuda_detail::DeviceBatch in;
  in.B = B;
  in.N = N;
  in.np = np;
  in.q = q.data();
  in.t = t.data();
  in.h = h.data();
  in.p = p.data();
  in.invalid = invalid.data();
  in.settings.keep = 1.0 - options.damping;
  in.settings.steps = options.newton_substeps;
  in.settings.nonlinear = options.method == Method::jacobi ? 1 : 0;
  in.settings.tol = options.tol;
  in.settings.rtol = options.rtol;
  in.settings.max_iterations = options.max_iterations;
  in.settings.divergence_factor = options.divergence_factor;
  in.settings.difference = options.newton_shift == NewtonShift::difference ? 1 : 0;
  in.check_every = settings.check_every;
  in.blocks_per_problem = settings.blocks_per_problem;
  in.keep_going = options.keep_going;
  cuda_detail::DeviceBatchResult out;
  out.q = q.data();  // the guesses are on the device once uploaded: the answers come back here
  out.records.resize(static_cast<std::size_t>(B));
  const std::string failed = (newton ? entry->run_newton : entry->run)(in, out);
  if (!failed.empty()) {
    batch.entries.clear();
    batch.refusal = failed;
    return batch;
  }

  const auto host_start = std::chrono::steady_clock::now();
  const double device_seconds = out.upload + out.sweeps + out.download;
  long converged = 0;
#pragma omp parallel for schedule(dynamic) reduction(+ : converged)
  for (int b = 0; b < B; ++b) {
    if (invalid[static_cast<std::size_t>(b)]) continue;
    const BatchProblem& bp = problems[static_cast<std::size_t>(b)];
    BatchEntry& e = batch.entries[static_cast<std::size_t>(b)];
    const cuda_detail::ProblemRecord& r = out.records[static_cast<std::size_t>(b)];
    const Problem problem = detail::entry_problem(base, bp);
    Trajectory& tr = e.trajectory;
    tr.N = N;
    tr.dim = dim;
    tr.t = t;
    tr.q.assign(q.begin() + static_cast<long>(b * per), q.begin() + static_cast<long>((b + 1) * per));
    Summary& s = e.summary;
    s.termination = to_termination(r.status);
    s.message = record_message(r, options, model);
    s.method = options.method;
    s.iterations = r.iterations;
    s.N = N;
    s.threads = 1;
    s.residual = r.residual;
    s.residual_floor = 16 * 2.220446049250313e-16 * r.scale;
    s.tolerance = r.target;
    s.final_time = t[static_cast<std::size_t>(N)];
    s.wall_seconds = device_seconds;
    s.action = discrete_action(problem, tr);
    s.error_note = "not estimated: the device batch solves one grid";
    if (s.converged()) {
      ++converged;
      if (settings.assess) s.point = assess_point(problem, tr, 1);
    }
  }
  batch.converged = converged;
  const auto end = std::chrono::steady_clock::now();
  batch.wall_seconds = std::chrono::duration<double>(end - start).count();
  if (times) {
    times->upload = out.upload;
    times->sweeps = out.sweeps;
    times->download = out.download;
    times->host = std::chrono::duration<double>(end - host_start).count();
    times->sweeps_run = out.sweeps_run;
  }
  return batch;
}

}  // namespace pardel
