// `pardel models` and `pardel kernels` (see inspect_commands.hpp).
#include "inspect_commands.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <nlohmann/json.hpp>

#include "arguments.hpp"
#include "pardel/app/scene.hpp"
#include "pardel/app/trajectory_io.hpp"
#include "pardel/pardel.hpp"

namespace pardel::cli {

using app::format_double;
using app::nearest_name;
using app::state_column_names;

int run_models(bool json) {
  const auto& models = bundled_models();
  if (json) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const pardel_model* m : models) {
      nlohmann::ordered_json j;
      j["name"] = m->name;
      j["source"] = m->source ? m->source : "";
      j["order"] = m->order;
      j["dim"] = m->dim;
      j["coords"] = std::vector<std::string>(m->coords, m->coords + m->ncoords);
      nlohmann::ordered_json params = nlohmann::ordered_json::object();
      for (int i = 0; i < m->nparams; ++i) params[m->param_names[i]] = m->param_defaults[i];
      j["params"] = params;
      j["time_dependent"] = m->time_dependent != 0;
      j["clock"] = m->clock != nullptr;
      nlohmann::ordered_json discs = nlohmann::ordered_json::array();
      for (int i = 0; i < m->ndiscretizations; ++i) {
        discs.push_back({{"name", m->discretizations[i].name},
                         {"consistency_order", m->discretizations[i].consistency_order}});
      }
      j["discretizations"] = discs;
      list.push_back(j);
    }
    std::cout << list.dump(2) << "\n";
    return 0;
  }
  if (models.empty()) {
    std::cout << "no bundled models in this build\n";
    return 0;
  }
  for (const pardel_model* m : models) {
    std::string coords;
    for (int i = 0; i < m->ncoords; ++i) coords += (i ? " " : "") + std::string(m->coords[i]);
    std::string params;
    for (int i = 0; i < m->nparams; ++i) {
      params += fmt::format("{}{}={}", i ? " " : "", m->param_names[i], m->param_defaults[i]);
    }
    std::string discs;
    for (int i = 0; i < m->ndiscretizations; ++i) discs += (i ? " " : "") + std::string(m->discretizations[i].name);
    std::cout << fmt::format("{}\n  coords: {}\n  order: {}{}{}\n  params: {}\n  discretizations: {}\n", m->name,
                             coords, m->order, m->time_dependent ? ", time-dependent" : "",
                             m->clock ? ", has a clock" : "", params.empty() ? "(none)" : params, discs);
  }
  return 0;
}

namespace {

std::string json_number(double v) {
  return std::isfinite(v) ? format_double(v) : "null";
}

std::string json_vector(const double* v, int n) {
  std::string out = "[";
  for (int i = 0; i < n; ++i) out += (i ? ", " : "") + json_number(v[i]);
  return out + "]";
}

std::string json_matrix(const double* m, int n) {
  std::string out = "[";
  for (int i = 0; i < n; ++i) out += (i ? ", " : "") + json_vector(m + static_cast<std::size_t>(i) * n, n);
  return out + "]";
}

}  // namespace

int run_kernels(const KernelArgs& args, const app::ModelResolver& resolve) {
  const pardel_model* model = nullptr;
  try {
    model = resolve(args.model);
  } catch (const std::exception& error) {
    throw UsageError(fmt::format("--model: cannot load '{}': {}", args.model, error.what()));
  }
  if (!model) {
    const std::string suggestion = nearest_name(args.model, bundled_model_names());
    throw UsageError(fmt::format("--model: unknown model '{}'{}", args.model,
                                 suggestion.empty() ? "" : fmt::format("; did you mean '{}'?", suggestion)));
  }
  const pardel_discretization* disc = find_discretization(*model, args.disc);
  if (!disc) {
    std::vector<std::string> names;
    for (int i = 0; i < model->ndiscretizations; ++i) names.push_back(model->discretizations[i].name);
    const std::string suggestion = nearest_name(args.disc, names);
    std::string all;
    for (const auto& n : names) all += (all.empty() ? "" : ", ") + n;
    throw UsageError(fmt::format("--disc: unknown discretization '{}' for model {}{} (it has: {})", args.disc,
                                 model->name, suggestion.empty() ? "" : fmt::format("; did you mean '{}'?", suggestion),
                                 all));
  }
  // The kernels are evaluated at the numbers as given: a step that is not positive, or a point
  // that is not finite, has no discrete Lagrangian to report.
  const double h = parse_number_option(args.h, "--h");
  if (!(std::isfinite(h) && h > 0)) throw UsageError(fmt::format("--h: the step must be a finite number > 0, got '{}'", args.h));
  const auto finite = [](double value, const std::string& text, const std::string& option) {
    if (!std::isfinite(value)) throw UsageError(fmt::format("{}: '{}' is not a finite number", option, text));
    return value;
  };
  const double t0 = finite(parse_number_option(args.t0, "--t0"), args.t0, "--t0");
  const double t1 = finite(parse_number_option(args.t1, "--t1"), args.t1, "--t1");
  std::string layout;
  for (const auto& name : state_column_names(*model)) layout += (layout.empty() ? "" : ",") + name;
  const auto q0 = parse_vector_option(args.q0, "--q0", model->dim, "order*ncoords values: " + layout);
  const auto q1 = parse_vector_option(args.q1, "--q1", model->dim, "order*ncoords values: " + layout);
  for (const auto* point : {&q0, &q1}) {
    const std::string option = point == &q0 ? "--q0" : "--q1";
    for (std::size_t i = 0; i < point->size(); ++i)
      if (!std::isfinite((*point)[i]))
        throw UsageError(fmt::format("{}: value {} ({}) is not a finite number", option, i + 1,
                                     state_column_names(*model)[i]));
  }
  std::vector<double> p(model->param_defaults, model->param_defaults + model->nparams);
  std::vector<std::string> names(model->param_names, model->param_names + model->nparams);
  std::vector<std::string> given;  // each param once: a second --param of it is refused, not silently the one used
  for (const auto& assignment : args.params) {
    const auto eq = assignment.find('=');
    if (eq == std::string::npos) throw UsageError(fmt::format("--param: '{}' is not NAME=VALUE", assignment));
    const std::string name = assignment.substr(0, eq);
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) {
      const std::string suggestion = nearest_name(name, names);
      throw UsageError(fmt::format("--param: model {} has no param '{}'{}", model->name, name,
                                   suggestion.empty() ? (names.empty() ? " (it has none)" : "")
                                                      : fmt::format("; did you mean '{}'?", suggestion)));
    }
    if (std::find(given.begin(), given.end(), name) != given.end())
      throw UsageError(fmt::format("--param: '{}' is given twice", name));
    given.push_back(name);
    p[it - names.begin()] = finite(parse_number_option(assignment.substr(eq + 1), "--param " + name),
                                   assignment.substr(eq + 1), "--param " + name);
  }
  const int m = model->dim;
  double Ld = 0;
  std::vector<double> D1(m), D2(m), D11(m * m), D12(m * m), D22(m * m);
  disc->full(h, t0, t1, q0.data(), q1.data(), p.data(), &Ld, D1.data(), D2.data(), D11.data(), D12.data(), D22.data());
  if (!model->clock && std::fabs((t1 - t0) - h) > 1e-12 * std::max(std::fabs(t1 - t0), h))
    std::cerr << fmt::format("pardel kernels: note: --h {} is not --t1 - --t0 = {}; model {} has no clock, and a solve "
                             "always passes h = t1 - t0\n",
                             args.h, format_double(t1 - t0), model->name);
  std::cout << "{\"Ld\": " << json_number(Ld) << ", \"D1\": " << json_vector(D1.data(), m)
            << ", \"D2\": " << json_vector(D2.data(), m) << ", \"D11\": " << json_matrix(D11.data(), m)
            << ", \"D12\": " << json_matrix(D12.data(), m) << ", \"D22\": " << json_matrix(D22.data(), m) << "}\n";
  long non_finite = std::isfinite(Ld) ? 0 : 1;
  for (const auto* values : {&D1, &D2, &D11, &D12, &D22})
    non_finite += std::count_if(values->begin(), values->end(), [](double v) { return !std::isfinite(v); });
  if (non_finite > 0) {
    std::cerr << fmt::format("pardel kernels: error: {} of the values are not finite (null in the JSON): the discrete "
                             "Lagrangian overflows or is undefined at these numbers\n",
                             non_finite);
    return 5;  // as a solve that meets a value that is not finite
  }
  return 0;
}

}  // namespace pardel::cli
