/**
 * @file api.cpp
 * Names, parsing and validation of the public API: methods, terminations, linear solvers, the
 * options' bounds and Options::is_valid, problem validation, discretization lookup and the
 * Summary's report.
 */
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "pardel/pardel.hpp"

#include "methods.hpp"

namespace pardel {
namespace {

std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

bool all_finite(const std::vector<double>& v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

/** Removes spaces, so that "trapezoid(alpha = 1)" matches "trapezoid(alpha=1)". */
std::string compact(std::string_view s) {
  std::string out;
  for (char c : s)
    if (c != ' ' && c != '\t') out += c;
  return out;
}

long long gcd(long long a, long long b) {
  while (b != 0) {
    const long long r = a % b;
    a = b;
    b = r;
  }
  return a < 0 ? -a : a;
}

/**
 * A number written as pardel-gen reads it, "0.7", "7/10", "-1/3", "2.5e-1", "+1", as the exact
 * reduced fraction pardel-gen prints ("7/10", "-1/3", "1/4", "1"); empty if it is not such a
 * number or does not fit in 64-bit integers.
 */
std::string rational_text(std::string_view text) {
  std::size_t i = 0;
  bool negative = false;
  if (i < text.size() && (text[i] == '+' || text[i] == '-')) negative = text[i++] == '-';
  constexpr long long kLimit = 100000000000000000LL;  // 1e17: products below stay in range
  long long num = 0, den = 1;
  bool digits = false;
  for (; i < text.size() && text[i] >= '0' && text[i] <= '9'; ++i, digits = true) {
    if (num > kLimit) return {};
    num = num * 10 + (text[i] - '0');
  }
  if (i < text.size() && text[i] == '.') {
    for (++i; i < text.size() && text[i] >= '0' && text[i] <= '9'; ++i, digits = true) {
      if (num > kLimit || den > kLimit) return {};
      num = num * 10 + (text[i] - '0');
      den *= 10;
    }
  }
  if (!digits) return {};
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    bool negative_exponent = false;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) negative_exponent = text[i++] == '-';
    int exponent = 0;
    bool exponent_digits = false;
    for (; i < text.size() && text[i] >= '0' && text[i] <= '9'; ++i, exponent_digits = true) {
      if (exponent > 40) return {};
      exponent = exponent * 10 + (text[i] - '0');
    }
    if (!exponent_digits) return {};
    for (int k = 0; k < exponent; ++k) {
      long long& target = negative_exponent ? den : num;
      if (target > kLimit) return {};
      target *= 10;
    }
  } else if (i < text.size() && text[i] == '/') {
    long long d = 0;
    bool d_digits = false;
    for (++i; i < text.size() && text[i] >= '0' && text[i] <= '9'; ++i, d_digits = true) {
      if (d > kLimit) return {};
      d = d * 10 + (text[i] - '0');
    }
    if (!d_digits || d == 0 || den != 1) return {};
    den = d;
  }
  if (i != text.size()) return {};
  const long long g = num == 0 ? den : gcd(num, den);
  num /= g;
  den /= g;
  std::string out = (negative && num != 0 ? "-" : "") + std::to_string(num);
  if (den != 1) out += "/" + std::to_string(den);
  return out;
}

/**
 * The canonical spelling of a discretization name, as pardel-gen writes it: spaces removed and a
 * parameter's value as an exact reduced fraction ("trapezoid(alpha=0.7)" is
 * "trapezoid(alpha=7/10)"). Bare names are resolved by the model's own bare_name entries.
 */
std::string canonical_discretization(std::string_view name) {
  std::string key = compact(name);
  const std::size_t open = key.find('('), eq = key.find('=');
  if (open != std::string::npos && eq != std::string::npos && open < eq && key.back() == ')') {
    const std::string value = rational_text(std::string_view(key).substr(eq + 1, key.size() - eq - 2));
    if (!value.empty()) key = key.substr(0, eq + 1) + value + ")";
  }
  return key;
}

}  // namespace

const pardel_discretization* find_discretization(const pardel_model& model, std::string_view name) {
  for (int i = 0; i < model.ndiscretizations; ++i)
    if (model.discretizations[i].name && name == model.discretizations[i].name) return &model.discretizations[i];
  const std::string key = canonical_discretization(name);
  for (int i = 0; i < model.ndiscretizations; ++i)
    if (model.discretizations[i].bare_name && key == model.discretizations[i].bare_name)
      return &model.discretizations[i];
  for (int i = 0; i < model.ndiscretizations; ++i)
    if (model.discretizations[i].name && key == canonical_discretization(model.discretizations[i].name))
      return &model.discretizations[i];
  return nullptr;
}

namespace {

/** One enum value and its name: each enum's names are one table of these. */
template <class E>
struct Named {
  E value;
  const char* name;
};

constexpr Named<Device> kDevices[] = {{Device::cpu, "cpu"}, {Device::cuda, "cuda"}};
constexpr Named<LinearSolver> kLinearSolvers[] = {{LinearSolver::block_ldlt, "ldlt"},
                                                  {LinearSolver::cyclic_reduction, "cyclic-reduction"}};
constexpr Named<NewtonShift> kNewtonShifts[] = {{NewtonShift::identity, "identity"},
                                                {NewtonShift::difference, "difference"}};
constexpr Named<Refinement> kRefinements[] = {
    {Refinement::automatic, "auto"}, {Refinement::on, "on"}, {Refinement::off, "off"}};
constexpr Named<ClockMode> kClockModes[] = {{ClockMode::none, "none"},
                                            {ClockMode::free_final_time, "free_final_time"},
                                            {ClockMode::fixed_total_time, "fixed_total_time"}};

template <class E, std::size_t K>
const char* name_in(const Named<E> (&table)[K], E value) {
  for (const Named<E>& entry : table)
    if (entry.value == value) return entry.name;
  return "unknown";
}

template <class E, std::size_t K>
bool in_table(const Named<E> (&table)[K], E value) {
  for (const Named<E>& entry : table)
    if (entry.value == value) return true;
  return false;
}

template <class E, std::size_t K>
bool parse_in(const Named<E> (&table)[K], std::string_view text, E* value) {
  for (const Named<E>& entry : table) {
    if (text == entry.name) {
      *value = entry.value;
      return true;
    }
  }
  return false;
}

template <class E, std::size_t K>
std::vector<std::string> names_in(const Named<E> (&table)[K]) {
  std::vector<std::string> names;
  for (const Named<E>& entry : table) names.emplace_back(entry.name);
  return names;
}

}  // namespace

// The methods' names are their rows of the catalogue (methods.hpp).
const char* to_string(Method method) {
  const detail::MethodRow* row = detail::method_row(method);
  return row ? row->name : "unknown";
}
bool parse_method(std::string_view text, Method* method) {
  const detail::MethodRow* row = detail::method_row(std::string(text));
  if (row) *method = row->method;
  return row != nullptr;
}
std::vector<std::string> method_names() {
  std::vector<std::string> names;
  for (const detail::MethodRow* row = detail::method_rows_begin(); row != detail::method_rows_end(); ++row)
    names.emplace_back(row->name);
  return names;
}

const char* to_string(Device device) { return name_in(kDevices, device); }
bool parse_device(std::string_view text, Device* device) { return parse_in(kDevices, text, device); }
std::vector<std::string> device_names() { return names_in(kDevices); }
const char* to_string(LinearSolver solver) { return name_in(kLinearSolvers, solver); }
bool parse_linear_solver(std::string_view text, LinearSolver* solver) { return parse_in(kLinearSolvers, text, solver); }
std::vector<std::string> linear_solver_names() { return names_in(kLinearSolvers); }

const char* to_string(NewtonShift shift) { return name_in(kNewtonShifts, shift); }
bool parse_newton_shift(std::string_view text, NewtonShift* shift) { return parse_in(kNewtonShifts, text, shift); }
std::vector<std::string> newton_shift_names() { return names_in(kNewtonShifts); }
const char* to_string(Refinement refinement) { return name_in(kRefinements, refinement); }
bool parse_refinement(std::string_view text, Refinement* refinement) { return parse_in(kRefinements, text, refinement); }
std::vector<std::string> refinement_names() { return names_in(kRefinements); }

const char* to_string(ClockMode mode) { return name_in(kClockModes, mode); }
bool parse_clock_mode(std::string_view text, ClockMode* mode) { return parse_in(kClockModes, text, mode); }
std::vector<std::string> clock_mode_names() { return names_in(kClockModes); }

const char* to_string(Termination termination) {
  switch (termination) {
    case Termination::converged: return "converged";
    case Termination::max_iterations: return "max_iterations";
    case Termination::diverged: return "diverged";
    case Termination::non_finite: return "non_finite";
    case Termination::invalid_input: return "invalid_input";
    case Termination::interrupted: return "interrupted";
    case Termination::stalled: return "stalled";
  }
  return "unknown";
}

const char* to_string(PointKind kind) {
  switch (kind) {
    case PointKind::unknown: return "unknown";
    case PointKind::minimum: return "minimum";
    case PointKind::saddle: return "saddle";
    case PointKind::degenerate: return "degenerate";
  }
  return "unknown";
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/** A numeric member of Options: its bound and how to read it. */
struct BoundedMember {
  OptionBound bound;
  double (*value)(const Options& options);
};

/** The bounds of the numeric options, in the order Options::is_valid checks them. */
const BoundedMember kBoundedMembers[] = {
    // name, low, included, high, included, 0 also valid, rule
    {{"tol", 0, true, kInf, false, false, "must be a finite number >= 0 (0: the relative test with rtol)"},
     [](const Options& o) { return o.tol; }},
    {{"rtol", 0, false, 1, false, false, "must be in (0, 1)"}, [](const Options& o) { return o.rtol; }},
    {{"max_iterations", 0, true, kInf, false, false, "must be >= 0 (0: evaluate the start only)"},
     [](const Options& o) { return static_cast<double>(o.max_iterations); }},
    {{"damping", 0, true, 1, false, false, "must be in [0, 1)"}, [](const Options& o) { return o.damping; }},
    {{"newton_substeps", 1, true, 1000, true, false, "must be between 1 and 1000"},
     [](const Options& o) { return static_cast<double>(o.newton_substeps); }},
    {{"threads", 0, true, 4096, true, false, "must be between 0 (all cores) and 4096"},
     [](const Options& o) { return static_cast<double>(o.threads); }},
    {{"refine_start_N", 2, true, kInf, false, true, "must be 0 (off; auto keeps its own levels) or >= 2"},
     [](const Options& o) { return static_cast<double>(o.refine_start_N); }},
    {{"refine_factor", 1, false, 16, true, false, "must be in (1, 16]"},
     [](const Options& o) { return o.refine_factor; }},
    {{"clock_update_every", 1, true, kInf, false, false, "must be >= 1"},
     [](const Options& o) { return static_cast<double>(o.clock_update_every); }},
    {{"history_every", 1, true, kInf, false, false, "must be >= 1"},
     [](const Options& o) { return static_cast<double>(o.history_every); }},
    {{"refine_settle", 0, false, 1, false, false, "must be in (0, 1)"},
     [](const Options& o) { return o.refine_settle; }},
    {{"divergence_factor", 1, false, kInf, true, false, "must be > 1"},
     [](const Options& o) { return o.divergence_factor; }},
    {{"accuracy", 0, false, kInf, false, true, "must be a positive finite number, or 0 (off)"},
     [](const Options& o) { return o.accuracy; }},
    {{"accuracy_max_N", 4, true, 1 << 30, true, false, "must be in [4, 2^30]"},
     [](const Options& o) { return static_cast<double>(o.accuracy_max_N); }},
};

}  // namespace

bool OptionBound::accepts(double value) const {
  if (zero_allowed && value == 0) return true;
  const bool above = low_included ? value >= low : value > low;
  const bool below = high_included ? value <= high : value < high;
  return above && below;
}

const OptionBound* option_bound(std::string_view name) {
  for (const BoundedMember& member : kBoundedMembers)
    if (name == member.bound.name) return &member.bound;
  return nullptr;
}

bool Options::is_valid(std::string* error) const {
  auto bad = [&](const char* name, const std::string& value, const char* rule) {
    if (error) *error = std::string("option ") + name + " = " + value + " is invalid: " + rule;
    return false;
  };
  for (const BoundedMember& member : kBoundedMembers) {
    const double value = member.value(*this);
    if (!member.bound.accepts(value)) return bad(member.bound.name, number(value), member.bound.rule);
  }
  if (!detail::method_row(method))
    return bad("method", std::to_string(static_cast<int>(method)), "is not a known method");
  if (!in_table(kDevices, device))
    return bad("device", std::to_string(static_cast<int>(device)), "is not a known device");
  if (!in_table(kLinearSolvers, linear_solver))
    return bad("linear_solver", std::to_string(static_cast<int>(linear_solver)), "is not a known linear solver");
  if (!in_table(kNewtonShifts, newton_shift))
    return bad("newton_shift", std::to_string(static_cast<int>(newton_shift)), "is not a known shift");
  if (!in_table(kRefinements, iterative_refinement))
    return bad("iterative_refinement", std::to_string(static_cast<int>(iterative_refinement)),
               "is not a known refinement mode");
  return true;
}

bool validate(const Problem& problem, const Trajectory& trajectory, std::string* error) {
  auto bad = [&](const std::string& msg) {
    if (error) *error = msg;
    return false;
  };
  if (!problem.model) return bad("problem.model is null");
  const pardel_model& m = *problem.model;
  if (m.abi_version != PARDEL_KERNEL_ABI_VERSION)
    return bad("problem.model '" + std::string(m.name ? m.name : "?") + "' has kernel ABI version " +
               std::to_string(m.abi_version) + ", this runtime expects " + std::to_string(PARDEL_KERNEL_ABI_VERSION));
  if (m.dim != m.order * m.ncoords || m.dim < 1)
    return bad("problem.model has inconsistent sizes (dim " + std::to_string(m.dim) + ", order " +
               std::to_string(m.order) + ", ncoords " + std::to_string(m.ncoords) + ")");
  if (!problem.discretization) return bad("problem.discretization is null");
  const pardel_discretization& d = *problem.discretization;
  if (!d.full || !d.sweep || !d.grad || !d.action)
    return bad(std::string("problem.discretization '") + (d.name ? d.name : "?") + "' lacks kernels");
  if (problem.N < 2) return bad("problem.N = " + std::to_string(problem.N) + " is invalid: must be >= 2");
  if (!std::isfinite(problem.t0)) return bad("problem.t0 = " + number(problem.t0) + " is not finite");
  if (!(problem.T > 0) || !std::isfinite(problem.T))
    return bad("problem.T = " + number(problem.T) + " is invalid: must be a positive finite number");
  const std::size_t dim = static_cast<std::size_t>(m.dim);
  if (problem.q0.size() != dim)
    return bad("problem.q0 has " + std::to_string(problem.q0.size()) + " values, the model needs dim = " +
               std::to_string(dim));
  if (problem.qN.size() != dim)
    return bad("problem.qN has " + std::to_string(problem.qN.size()) + " values, the model needs dim = " +
               std::to_string(dim));
  if (!all_finite(problem.q0)) return bad("problem.q0 has a non-finite value");
  if (!all_finite(problem.qN)) return bad("problem.qN has a non-finite value");
  if (!problem.params.empty() && problem.params.size() != static_cast<std::size_t>(m.nparams))
    return bad("problem.params has " + std::to_string(problem.params.size()) + " values, the model has " +
               std::to_string(m.nparams) + " params");
  if (!all_finite(problem.params)) return bad("problem.params has a non-finite value");
  if (problem.clock != ClockMode::none && !m.clock)
    return bad("problem.clock needs a clock but model '" + std::string(m.name ? m.name : "?") + "' declares none");
  if (problem.clock != ClockMode::none && !problem.knots.empty())
    return bad("problem.knots cannot be combined with a clock (knot times are grid times)");
  if (!problem.times.empty()) {
    if (problem.clock != ClockMode::none)
      return bad("problem.times cannot be combined with a clock (the clock sets the node times)");
    if (problem.times.size() != static_cast<std::size_t>(problem.N) + 1)
      return bad("problem.times has " + std::to_string(problem.times.size()) + " values, expected N+1 = " +
                 std::to_string(problem.N + 1));
    if (problem.times.front() != problem.t0 || problem.times.back() != problem.t0 + problem.T)
      return bad("problem.times must run from t0 = " + number(problem.t0) + " to t0 + T = " +
                 number(problem.t0 + problem.T) + ", not from " + number(problem.times.front()) + " to " +
                 number(problem.times.back()));
    for (std::size_t k = 0; k + 1 < problem.times.size(); ++k)
      if (!(problem.times[k + 1] > problem.times[k]) || !std::isfinite(problem.times[k + 1]))
        return bad("problem.times must increase strictly: times[" + std::to_string(k + 1) + "] = " +
                   number(problem.times[k + 1]) + " after times[" + std::to_string(k) + "] = " +
                   number(problem.times[k]));
  }
  for (std::size_t a = 0; a < problem.knots.size(); ++a) {
    const Knot& k = problem.knots[a];
    if (!std::isfinite(k.t)) return bad("problem.knots[" + std::to_string(a) + "].t is not finite");
    if (k.q.size() != static_cast<std::size_t>(m.ncoords))
      return bad("problem.knots[" + std::to_string(a) + "].q has " + std::to_string(k.q.size()) +
                 " values, the model has ncoords = " + std::to_string(m.ncoords));
    if (!all_finite(k.q)) return bad("problem.knots[" + std::to_string(a) + "].q has a non-finite value");
  }
  if (trajectory.dim != m.dim)
    return bad("trajectory.dim = " + std::to_string(trajectory.dim) + " differs from the model's dim = " +
               std::to_string(m.dim));
  if (trajectory.N < 1) return bad("trajectory.N = " + std::to_string(trajectory.N) + " is invalid: must be >= 1");
  if (trajectory.q.size() != (static_cast<std::size_t>(trajectory.N) + 1) * dim)
    return bad("trajectory.q has " + std::to_string(trajectory.q.size()) + " values, expected (N+1)*dim = " +
               std::to_string((static_cast<std::size_t>(trajectory.N) + 1) * dim));
  if (!trajectory.t.empty() && trajectory.t.size() != static_cast<std::size_t>(trajectory.N) + 1)
    return bad("trajectory.t has " + std::to_string(trajectory.t.size()) + " values, expected N+1 = " +
               std::to_string(trajectory.N + 1));
  for (std::size_t i = 0; i < trajectory.q.size(); ++i)
    if (!std::isfinite(trajectory.q[i]))
      return bad("trajectory has a non-finite value at node " + std::to_string(i / dim));
  return true;
}

std::string Summary::brief_report() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%s: %s after %ld iterations (N = %d, %d thread%s): DEL residual %.3e, action %.10g, "
                "final time %.10g, %.3f ms",
                to_string(method), to_string(termination), iterations, N, threads, threads == 1 ? "" : "s", residual,
                action, final_time, wall_seconds * 1e3);
  std::string out = buf;
  if (std::isfinite(error_estimate)) {
    std::snprintf(buf, sizeof buf, ", error estimate %.3e%s", error_estimate,
                  extrapolated ? " (of the discrete solution; the path returned is extrapolated from it)" : "");
    out += buf;
  } else {
    out += ", error not estimated";
  }
  if (!message.empty()) out += "\n  " + message;
  if (!error_note.empty()) out += "\n  error estimate: " + error_note;
  if (!refinement_note.empty()) out += "\n  iterative refinement: " + refinement_note;
  if (!grid_note.empty()) {
    std::string sizes;
    for (std::size_t i = 0; i < grid_sizes.size(); ++i) sizes += (i ? ", " : "") + std::to_string(grid_sizes[i]);
    out += "\n  adaptive grid: " + grid_note + (sizes.empty() ? "" : " (N = " + sizes + ")");
  }
  return out;
}

}  // namespace pardel
