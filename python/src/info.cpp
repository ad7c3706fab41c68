/**
 * @file info.cpp
 * The dictionaries of pardel.Model.info and pardel.Scene.info.
 */
#include "bindings.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace pardel::python {

namespace {

/** A file path as os.fsdecode gives it: bytes that are not UTF-8 become lone surrogates, so that
 *  os.fsencode gives the path's bytes back. */
py::str path_str(const std::string& path) {
  PyObject* text = PyUnicode_DecodeFSDefaultAndSize(path.data(), static_cast<Py_ssize_t>(path.size()));
  if (!text) throw py::error_already_set();
  return py::reinterpret_steal<py::str>(text);
}

}  // namespace

py::dict model_info(const ModelHandle& handle) {
  const pardel_model& m = *handle.model;
  py::dict out;
  out["name"] = m.name;
  out["source"] = path_str(m.source ? m.source : "");
  out["order"] = m.order;
  out["ncoords"] = m.ncoords;
  out["dim"] = m.dim;
  out["coords"] = std::vector<std::string>(m.coords, m.coords + m.ncoords);
  py::dict params;
  for (int i = 0; i < m.nparams; ++i) params[py::str(m.param_names[i])] = m.param_defaults[i];
  out["params"] = params;
  std::vector<std::string> discs;
  for (int i = 0; i < m.ndiscretizations; ++i) discs.push_back(m.discretizations[i].name);
  out["discretizations"] = discs;
  out["has_clock"] = m.clock != nullptr;
  out["time_dependent"] = m.time_dependent != 0;
  return out;
}

py::dict scene_info(const Scene& s) {
  py::dict out;
  out["path"] = path_str(s.path);
  out["model"] = ModelHandle{s.model};
  out["model_spec"] = path_str(s.model_spec);  // a .lag path need not be UTF-8
  out["discretization"] = s.discretization;
  std::vector<double> params = s.problem.params;
  py::dict named;
  for (int i = 0; i < s.model->nparams && static_cast<std::size_t>(i) < params.size(); ++i)
    named[py::str(s.model->param_names[i])] = params[static_cast<std::size_t>(i)];
  out["params"] = named;
  out["t0"] = s.problem.t0;
  out["T"] = s.problem.T;
  out["N"] = s.problem.N;
  out["q0"] = vector(s.problem.q0);
  out["qN"] = vector(s.problem.qN);
  py::list knots;
  for (const Knot& k : s.problem.knots) knots.append(py::make_tuple(k.t, vector(k.q)));
  out["knots"] = knots;
  out["clock"] = to_string(s.problem.clock);
  out["method"] = to_string(s.options.method);
  out["tol"] = s.options.tol;
  out["rtol"] = s.options.rtol;
  out["max_iterations"] = s.options.max_iterations;
  out["threads"] = s.options.threads;
  out["output_dir"] = s.output_dir;
  return out;
}

}  // namespace pardel::python
