/**
 * @file main.cpp
 * pardel-ipopt: the command line of the IPOPT peer. Minimizes a model's discrete action with IPOPT
 * from the straight-line guess and prints IPOPT's status, iterations, time, the recomputed DEL
 * residual and the action, e.g.
 *   pardel-ipopt --model fuel_nav --T 30 --N 200 --q0 0,0 --qN 6,5
 * Params by name and the trajectory file are pardel's own (pardel::params_by_name,
 * pardel::app::trajectory_csv), so that `pardel check --trajectory` reads what --output writes.
 */
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "ipopt_peer.hpp"
#include "pardel/app/trajectory_io.hpp"
#include "pardel/model_loader.hpp"

namespace {

const char* const kUsage =
    "usage: pardel-ipopt --model NAME|FILE.lag --N N --T T --q0 V,... --qN V,... [options]\n"
    "  --disc NAME          discretization (default: the model's first)\n"
    "  --t0 T0              initial time (default 0)\n"
    "  --param NAME=VALUE   set a model parameter (repeatable)\n"
    "  --tol TOL            DEL residual tolerance (default 1e-10)\n"
    "  --max-iter N         IPOPT iterations (default 3000)\n"
    "  --no-acceptable      disable IPOPT's 'acceptable' early stop\n"
    "  --threads N          threads for kernel evaluation (default 1)\n"
    "  --print-level L      IPOPT print level (default 0)\n"
    "  --output FILE        write the final trajectory as a trajectory.csv (k, t, state columns)\n"
    "  --csv                print one CSV line: model,N,status,iterations,seconds,residual,action\n";

[[noreturn]] void fail(const std::string& message) {
  std::fprintf(stderr, "pardel-ipopt: error: %s\n%s", message.c_str(), kUsage);
  std::exit(2);
}

double parse_double(const std::string& key, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    fail(key + ": '" + text + "' is not a finite number");
  return v;
}

long parse_long(const std::string& key, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE) fail(key + ": '" + text + "' is not an integer");
  return v;
}

std::vector<double> parse_list(const std::string& key, const std::string& text) {
  std::vector<double> values;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    values.push_back(parse_double(key, text.substr(start, comma == std::string::npos ? std::string::npos
                                                                                     : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return values;
}

}  // namespace

int main(int argc, char** argv) {
  std::string model_name, disc_name, output;
  std::map<std::string, double> params;
  pardel::Problem problem;
  pardel::peer::IpoptOptions options;
  bool have_N = false, have_T = false, csv = false;
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) fail(key + ": missing value");
      return argv[++i];
    };
    if (key == "--help" || key == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (key == "--model") {
      model_name = value();
    } else if (key == "--disc") {
      disc_name = value();
    } else if (key == "--N") {
      const long N = parse_long(key, value());
      if (N < 2 || N > 2000000000L) fail("--N: " + std::to_string(N) + " must be in 2..2e9");
      problem.N = static_cast<int>(N);
      have_N = true;
    } else if (key == "--T") {
      problem.T = parse_double(key, value());
      if (!(problem.T > 0)) fail("--T: must be positive");
      have_T = true;
    } else if (key == "--t0") {
      problem.t0 = parse_double(key, value());
    } else if (key == "--q0") {
      problem.q0 = parse_list(key, value());
    } else if (key == "--qN") {
      problem.qN = parse_list(key, value());
    } else if (key == "--param") {
      const std::string v = value();
      const std::size_t eq = v.find('=');
      if (eq == std::string::npos || eq == 0) fail("--param: '" + v + "' is not NAME=VALUE");
      params[v.substr(0, eq)] = parse_double("--param " + v.substr(0, eq), v.substr(eq + 1));
    } else if (key == "--tol") {
      options.tol = parse_double(key, value());
    } else if (key == "--max-iter") {
      options.max_iterations = static_cast<int>(parse_long(key, value()));
    } else if (key == "--no-acceptable") {
      options.allow_acceptable = false;
    } else if (key == "--threads") {
      options.threads = static_cast<int>(parse_long(key, value()));
    } else if (key == "--print-level") {
      options.print_level = static_cast<int>(parse_long(key, value()));
    } else if (key == "--output") {
      output = value();
    } else if (key == "--csv") {
      csv = true;
    } else {
      fail("unknown option '" + key + "'");
    }
  }
  if (model_name.empty()) fail("--model is required");
  if (!have_N) fail("--N is required");
  if (!have_T) fail("--T is required");
  std::string error;
  if (!options.is_valid(&error)) fail(error);

  try {
    problem.model = pardel::resolve_model(model_name);
  } catch (const pardel::ModelLoadError& e) {
    std::fprintf(stderr, "pardel-ipopt: error: --model %s: %s\n", model_name.c_str(), e.what());
    return 2;
  }
  if (!problem.model) fail("--model: unknown model '" + model_name + "'");
  const pardel_model& m = *problem.model;
  if (!disc_name.empty()) {
    problem.discretization = pardel::find_discretization(m, disc_name);
    if (!problem.discretization) {
      std::string names;
      for (int i = 0; i < m.ndiscretizations; ++i) names += std::string(i ? ", " : "") + m.discretizations[i].name;
      fail("--disc: model '" + std::string(m.name) + "' has no discretization '" + disc_name + "' (has: " + names +
           ")");
    }
  }
  if (problem.q0.size() != static_cast<std::size_t>(m.dim))
    fail("--q0: model '" + std::string(m.name) + "' needs " + std::to_string(m.dim) + " values");
  if (problem.qN.size() != static_cast<std::size_t>(m.dim))
    fail("--qN: model '" + std::string(m.name) + "' needs " + std::to_string(m.dim) + " values");
  if (!pardel::params_by_name(m, params, &problem.params, &error)) fail("--param: " + error);

  pardel::Trajectory trajectory = pardel::peer::straight_line(problem);
  const pardel::peer::IpoptResult result = pardel::peer::solve_ipopt(problem, options, trajectory);
  if (!result.ran) {
    std::fprintf(stderr, "pardel-ipopt: error: %s\n", result.message.c_str());
    return 2;
  }
  if (csv) {
    std::printf("%s,%d,%s,%d,%.6f,%.6e,%.12g\n", m.name, problem.N, result.status.c_str(), result.iterations,
                result.wall_seconds, result.residual, result.action);
  } else {
    std::printf("%s\n", result.brief_report().c_str());
  }
  if (!output.empty()) {
    try {
      pardel::app::write_file_atomic(output, pardel::app::trajectory_csv(m, trajectory));
    } catch (const std::runtime_error& e) {
      std::fprintf(stderr, "pardel-ipopt: error: --output: %s\n", e.what());
      return 2;
    }
  }
  return result.converged ? 0 : 1;
}
