/**
 * @file check.cpp
 * What pardel computes without solving: `pardel check` at a trajectory (pardel.check) and a model's
 * kernels at one interval (`pardel kernels`).
 */
#include "bindings.hpp"

#include <fmt/format.h>

#include <cstddef>
#include <string>
#include <vector>

#include "pardel/app/outputs.hpp"
#include "pardel/app/trajectory_io.hpp"

namespace pardel::python {

/** `pardel check`: the certificate, residual and action at a trajectory (the scene's guess when
 *  q is None), as a dict in the layout of `pardel check --json` (app::certificate_json, every
 *  member of pardel::Certificate), the certificate dictionary with one more key: report (the text
 *  `pardel check` prints). */
py::object check_scene(Scene scene, const py::object& q, const py::object& t) {
  // A given trajectory is checked on its own nodes, not resampled to the scene's N.
  if (!q.is_none()) {
    const auto rows = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(q);
    if (rows && rows.ndim() == 2 && rows.shape(0) >= 2) scene.problem.N = static_cast<int>(rows.shape(0) - 1);
  }
  Trajectory trajectory = initial_trajectory(scene, q, t, "q");
  if (!q.is_none()) {
    if (scene.options.accuracy > 0 && t.is_none())
      throw InputError("q: the scene chooses its grid (grid.accuracy), so a path is checked on its own node times: "
                       "give the Result, not its array q");
    const std::string mismatch = app::fit_to_path(scene, trajectory);
    if (!mismatch.empty()) throw InputError("q: " + mismatch);
  }
  Certificate certificate;
  double residual = 0, action = 0;
  {
    py::gil_scoped_release release;
    certificate = certify(scene.problem, trajectory, scene.options.threads);
    residual = residual_norm(scene.problem, trajectory);
    action = discrete_action(scene.problem, trajectory);
  }
  nlohmann::ordered_json j;
  j["trajectory"] = q.is_none() ? "initial guess" : "given";
  j["N"] = trajectory.N;
  j["residual"] = residual;
  j["action"] = action;
  nlohmann::ordered_json c = app::certificate_json(certificate, static_cast<std::size_t>(-1));
  c["report"] = certificate.report();
  j["certificate"] = std::move(c);
  return json_value(j);
}

/** The kernels of a model at one interval (what `pardel kernels` prints). */
py::dict kernels(const ModelHandle& handle, const std::string& discretization, double h, double t0, double t1,
                 const std::vector<double>& q0, const std::vector<double>& q1, const std::vector<double>& params) {
  const pardel_model& model = *handle.model;
  const pardel_discretization* disc = find_discretization(model, discretization);
  if (!disc) throw InputError(fmt::format("unknown discretization '{}' for model {}", discretization, model.name));
  const std::size_t m = static_cast<std::size_t>(model.dim);
  if (q0.size() != m || q1.size() != m)
    throw InputError(fmt::format("q0 and q1 need {} values each (model {} has dim {})", m, model.name, m));
  if (params.size() != static_cast<std::size_t>(model.nparams))
    throw InputError(fmt::format("params: {} values given; model {} has {}", params.size(), model.name, model.nparams));
  double Ld = 0;
  std::vector<double> D1(m), D2(m), D11(m * m), D12(m * m), D22(m * m);
  disc->full(h, t0, t1, q0.data(), q1.data(), params.data(), &Ld, D1.data(), D2.data(), D11.data(), D12.data(),
             D22.data());
  py::dict out;
  out["Ld"] = Ld;
  out["D1"] = vector(D1);
  out["D2"] = vector(D2);
  out["D11"] = matrix(D11, m, m);
  out["D12"] = matrix(D12, m, m);
  out["D22"] = matrix(D22, m, m);
  return out;
}

}  // namespace pardel::python
