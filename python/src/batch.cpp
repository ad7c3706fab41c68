/**
 * @file batch.cpp
 * pardel.solve_batch: problems that differ from one scene in their boundary values, params and
 * guesses, solved together by pardel::solve_batch while the calling thread watches for Ctrl-C.
 */
#include "bindings.hpp"

#include <fmt/format.h>

#include <atomic>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "pardel/app/solve.hpp"

namespace pardel::python {

namespace {

/** A 2-D (rows x cols) or 3-D array argument of pardel.solve_batch as float64, its shape checked
 *  against `expected` (-1: any), the message naming the argument. */
py::array_t<double, py::array::c_style | py::array::forcecast> batch_array(const py::object& value, const char* name,
                                                                          std::vector<py::ssize_t> expected,
                                                                          const std::string& what) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  bool fits = a && a.ndim() == static_cast<py::ssize_t>(expected.size());
  for (std::size_t i = 0; fits && i < expected.size(); ++i) fits = expected[i] < 0 || a.shape(i) == expected[i];
  if (!fits) {
    const std::string shape = a ? fmt::format("({})", fmt::join(std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim()), ", "))
                                : "no array";
    throw InputError(fmt::format("{}: shape {} given; expected {}", name, shape, what));
  }
  return a;
}

}  // namespace

/**
 * pardel.solve_batch: B problems that differ from `scene` in q0, qN (B x dim), params (B x nparams,
 * or None: the scene's) and guess (B x (M+1) x dim, resampled to N as solve_scene does; None: the
 * scene's guess), solved by pardel::solve_batch with the GIL released while this thread watches for
 * Ctrl-C (which stops the batch and is raised once it has stopped). `threads`: problems at once.
 * A batch refused as a whole (memory) raises PardelError; each problem's result is solve_scene's,
 * a problem never started (interrupted) holding its initial guess, its N that guess's grid; the
 * messages of the solves Ctrl-C stopped name it (app::name_interruption).
 */
py::dict solve_batch_scene(Scene scene, const py::object& q0, const py::object& qN, const py::object& params,
                           const py::object& guess, const py::object& threads) {
  if (!threads.is_none()) scene.options.threads = threads.cast<int>();
  const pardel_model& model = *scene.model;
  const py::ssize_t dim = model.dim, np = model.nparams;
  const auto q0s = batch_array(q0, "q0", {-1, dim}, fmt::format("(B, {}) (model {} has dim {})", dim, model.name, dim));
  const py::ssize_t B = q0s.shape(0);
  const auto qNs = batch_array(qN, "qN", {B, dim}, fmt::format("({}, {}), as q0", B, dim));
  std::vector<BatchProblem> problems(static_cast<std::size_t>(B));
  std::vector<Scene> scenes(static_cast<std::size_t>(B), scene);
  py::array_t<double, py::array::c_style | py::array::forcecast> ps;
  if (!params.is_none()) ps = batch_array(params, "params", {B, np}, fmt::format("({}, {}) (model {} has {} params)", B, np, model.name, np));
  py::array_t<double, py::array::c_style | py::array::forcecast> gs;
  if (!guess.is_none()) gs = batch_array(guess, "guess", {B, -1, dim}, fmt::format("({}, M+1, {})", B, dim));
  const bool have_params = !params.is_none(), have_guess = !guess.is_none();
  if (have_guess && gs.shape(1) < 2) throw InputError("guess: at least 2 nodes per problem were expected");
  for (py::ssize_t i = 0; i < B; ++i) {
    Problem& problem = scenes[static_cast<std::size_t>(i)].problem;
    problem.q0.assign(q0s.data(i, 0), q0s.data(i, 0) + dim);
    problem.qN.assign(qNs.data(i, 0), qNs.data(i, 0) + dim);
    if (have_params && np > 0) problem.params.assign(ps.data(i, 0), ps.data(i, 0) + np);
    BatchProblem& b = problems[static_cast<std::size_t>(i)];
    b.q0 = problem.q0;
    b.qN = problem.qN;
    b.params = problem.params;
    if (have_guess)
      b.guess = initial_trajectory(scenes[static_cast<std::size_t>(i)], py::array(gs[py::int_(i)]), py::none());
    else if (scene.guess.kind != app::GuessKind::linear)
      b.guess = app::make_initial_guess(scenes[static_cast<std::size_t>(i)]);
  }
  std::atomic<bool> stop{false};
  scene.options.on_iteration = nullptr;
  scene.options.keep_going = [&stop] { return !stop.load(std::memory_order_relaxed); };
  BatchSummary batch;
  std::unique_ptr<py::error_already_set> pending =
      watching_signals([&] { batch = pardel::solve_batch(scene.problem, scene.options, problems); }, stop);
  // An interruption (Ctrl-C) is raised by the package with the batch so far: the problems that
  // ended, those stopped (interrupted) and those never started (their initial guesses).
  if (pending && !pending->matches(PyExc_KeyboardInterrupt)) throw std::move(*pending);
  if (!batch.refusal.empty()) {
    if (pending) throw std::move(*pending);
    throw InputError(fmt::format("{}: {}", scene.path, batch.refusal));
  }
  py::list results;
  for (py::ssize_t i = 0; i < B; ++i) {
    BatchEntry& e = batch.entries[static_cast<std::size_t>(i)];
    const Scene& s = scenes[static_cast<std::size_t>(i)];
    // Only Ctrl-C stops a batch (it takes no on_iteration): the stopped solves' messages say so.
    if (pending) app::name_interruption(e.summary, kStoppedByCtrlC);
    if (e.trajectory.N == 0) {  // never started (or refused): its initial guess, and N that guess's grid
      const BatchProblem& b = problems[static_cast<std::size_t>(i)];
      e.trajectory = b.guess.N > 0 ? b.guess : linear_guess(s.problem);
      e.summary.N = e.trajectory.N;
    }
    results.append(result_dict(s, e.summary, e.trajectory, false));
  }
  py::dict out;
  out["results"] = results;
  out["threads"] = batch.threads;
  out["wall_seconds"] = batch.wall_seconds;
  out["pending"] = pending && pending->value() ? pending->value() : py::none();
  return out;
}

}  // namespace pardel::python
