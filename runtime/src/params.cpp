/**
 * @file params.cpp
 * A model's params by name: the index of a name in the model's declaration order, and the
 * vector of Problem::params built from the defaults and a map of named values.
 */
#include <string>
#include <utility>

#include "pardel/pardel.hpp"

namespace pardel {

int find_param(const pardel_model& model, std::string_view name) {
  for (int i = 0; i < model.nparams; ++i) {
    if (name == model.param_names[i]) return i;
  }
  return -1;
}

bool params_by_name(const pardel_model& model, const std::map<std::string, double>& values,
                    std::vector<double>* params, std::string* error) {
  std::vector<double> out(model.param_defaults, model.param_defaults + model.nparams);
  for (const auto& [name, value] : values) {
    const int i = find_param(model, name);
    if (i < 0) {
      if (error) {
        std::string known;
        for (int j = 0; j < model.nparams; ++j) known += std::string(j ? ", " : "") + model.param_names[j];
        *error = "model " + std::string(model.name) + " has no param '" + name + "' (its params: " +
                 (known.empty() ? "none" : known) + ")";
      }
      return false;
    }
    out[static_cast<std::size_t>(i)] = value;
  }
  *params = std::move(out);
  return true;
}

}  // namespace pardel
