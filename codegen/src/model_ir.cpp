/**
 * @file model_ir.cpp
 * Builds the IR of a model (discrete Lagrangian, its first and second derivatives, CSE per
 * kernel variant) and writes it, and its operation counts, as JSON (nlohmann-json) or text.
 */
#include "pardel_codegen/model_ir.hpp"

#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "pardel_codegen/discretize.hpp"
#include "pardel_codegen/lag_parser.hpp"
#include "pardel/kernel_abi.h"  // PARDEL_KERNEL_ABI_VERSION: the IR names the ABI its kernels follow

#ifndef PARDEL_GEN_VERSION
#define PARDEL_GEN_VERSION "0.0.0"
#endif

namespace pardel_codegen {

const char* generator_version() { return PARDEL_GEN_VERSION; }

const std::vector<std::string>& kernel_variants() {
  static const std::vector<std::string> v = {"full", "sweep", "grad", "action"};
  return v;
}

namespace {

using GiNaC::ex;
using Json = nlohmann::ordered_json;  // keys in the order they are set

std::vector<KernelInput> kernel_inputs(const KernelSymbols& s) {
  std::vector<KernelInput> in;
  in.push_back({s.h, "h", "h"});
  in.push_back({s.t0, "t0", "t0"});
  in.push_back({s.t1, "t1", "t1"});
  for (std::size_t i = 0; i < s.q0.size(); ++i) in.push_back({s.q0[i], "q0[" + std::to_string(i) + "]", "q0"});
  for (std::size_t i = 0; i < s.q1.size(); ++i) in.push_back({s.q1[i], "q1[" + std::to_string(i) + "]", "q1"});
  for (std::size_t i = 0; i < s.p.size(); ++i) in.push_back({s.p[i], "p[" + std::to_string(i) + "]", "p"});
  return in;
}

struct Derivatives {
  ex Ld;
  std::vector<ex> D1, D2, D11, D12, D22;  // matrices row-major m x m
};

Derivatives differentiate(const ex& Ld, const KernelSymbols& s) {
  const std::size_t m = s.q0.size();
  Derivatives d;
  d.Ld = Ld;
  for (std::size_t i = 0; i < m; ++i) {
    d.D1.push_back(Ld.diff(s.q0[i]));
    d.D2.push_back(Ld.diff(s.q1[i]));
  }
  d.D11.assign(m * m, 0);
  d.D12.assign(m * m, 0);
  d.D22.assign(m * m, 0);
  for (std::size_t i = 0; i < m; ++i) {
    for (std::size_t j = 0; j < m; ++j) {
      if (j >= i) {
        d.D11[i * m + j] = d.D11[j * m + i] = d.D1[i].diff(s.q0[j]);
        d.D22[i * m + j] = d.D22[j * m + i] = d.D2[i].diff(s.q1[j]);
      }
      d.D12[i * m + j] = d.D1[i].diff(s.q1[j]);
    }
  }
  return d;
}

void add_vector(std::vector<KernelOutput>& out, const std::string& name, const std::vector<ex>& v) {
  for (std::size_t i = 0; i < v.size(); ++i) out.push_back({name + "[" + std::to_string(i) + "]", v[i]});
}

std::vector<std::string> unused(const KernelCode& code, const std::vector<std::string>& args) {
  std::vector<std::string> out;
  for (const std::string& a : args) {
    if (!code.used_groups.count(a)) out.push_back(a);
  }
  return out;
}

/** The length of the valid UTF-8 sequence that starts at s[i] (1 to 4), or 0 when it is not one. */
std::size_t utf8_length(const std::string& s, std::size_t i) {
  const auto at = [&](std::size_t k) { return i + k < s.size() ? static_cast<unsigned char>(s[i + k]) : 0u; };
  const unsigned c = at(0);
  if (c < 0x80) return 1;
  auto cont = [&](std::size_t k, unsigned lo = 0x80, unsigned hi = 0xbf) { return at(k) >= lo && at(k) <= hi; };
  if (c >= 0xc2 && c <= 0xdf) return cont(1) ? 2 : 0;
  if (c == 0xe0) return cont(1, 0xa0) && cont(2) ? 3 : 0;
  if (c == 0xed) return cont(1, 0x80, 0x9f) && cont(2) ? 3 : 0;
  if (c >= 0xe1 && c <= 0xef) return cont(1) && cont(2) ? 3 : 0;
  if (c == 0xf0) return cont(1, 0x90) && cont(2) && cont(3) ? 4 : 0;
  if (c >= 0xf1 && c <= 0xf3) return cont(1) && cont(2) && cont(3) ? 4 : 0;
  if (c == 0xf4) return cont(1, 0x80, 0x8f) && cont(2) && cont(3) ? 4 : 0;
  return 0;
}

/*
 * Bytes that are not UTF-8. A file name in another encoding (the IR's "source") is written with
 * each byte that is not part of valid UTF-8 as the lone surrogate U+DC00 + byte, as Python's
 * surrogateescape decodes it, so that render.py gets the original bytes back
 * (`encode("utf-8", "surrogateescape")`). nlohmann-json writes valid UTF-8 only, so such a byte
 * enters the JSON value as a mark, NUL and the byte's two hex digits, which the dump writes as
 * `\u0000` and those digits; dump() turns that escape into `\udcXX`. A NUL of the text itself is
 * marked too (as `00`), so that every `\u0000` in the dump is a mark.
 */
Json text(const std::string& s) {
  bool plain = true;
  for (std::size_t i = 0; i < s.size() && plain;) {
    const std::size_t n = utf8_length(s, i);
    plain = n != 0 && s[i] != '\0';
    i += n;
  }
  if (plain) return s;
  std::string marked;
  for (std::size_t i = 0; i < s.size();) {
    const std::size_t n = utf8_length(s, i);
    if (n == 0 || s[i] == '\0') {
      char hex[3];
      std::snprintf(hex, sizeof hex, "%02x", static_cast<unsigned char>(s[i]));
      marked += '\0';
      marked += hex;
      i += 1;
    } else {
      marked.append(s, i, n);
      i += n;
    }
  }
  return marked;
}

/** JSON text of `j` (indented by 2, UTF-8) with the marks of text() as their escapes. */
std::string dump(const Json& j) {
  const std::string out = j.dump(2);
  std::string unmarked;
  unmarked.reserve(out.size());
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (out[i] != '\\') {
      unmarked += out[i];
    } else if (out.compare(i, 6, "\\u0000") == 0 && i + 8 <= out.size()) {
      const std::string digits = out.substr(i + 6, 2);  // "00": a NUL of the text itself
      unmarked += digits == "00" ? std::string("\\u0000") : "\\udc" + digits;
      i += 7;
    } else {  // any other escape: its backslash and the character after it
      unmarked += out[i];
      if (i + 1 < out.size()) unmarked += out[++i];
    }
  }
  return unmarked + "\n";
}

Json kernel_json(const KernelIR& k) {
  Json j;
  j["variant"] = text(k.variant);
  j["function"] = text(k.function);
  j["ops_before_cse"] = k.code.ops_before;
  j["ops_after_cse"] = k.code.ops_after;
  j["unused_inputs"] = Json::array();
  for (const std::string& name : k.unused_inputs) j["unused_inputs"].push_back(text(name));
  j["temporaries"] = Json::array();
  for (const auto& t : k.code.temporaries) j["temporaries"].push_back(Json{{"name", text(t.name)}, {"expr", text(t.expr)}});
  j["outputs"] = Json::array();
  for (const auto& o : k.code.outputs) j["outputs"].push_back(Json{{"target", text(o.name)}, {"expr", text(o.expr)}});
  return j;
}

Json optional_kernel_json(const std::optional<KernelIR>& k) { return k ? kernel_json(*k) : Json(nullptr); }

}  // namespace

namespace {

/** The interval kernels of a Galerkin discretization with interior values: the action S over
 *  x = [q0, z, q1], its gradient and Hessian, and z's starting values. */
std::vector<KernelIR> interval_kernels(const LagModel& model, const DiscretizationSpec& spec, const KernelSymbols& s,
                                       const CseOptions& options, int* interior_dim, std::vector<KernelIR>* extended) {
  const GalerkinInterval gi = galerkin_interval(model, spec, s);
  *interior_dim = static_cast<int>(gi.z.size());
  std::vector<KernelInput> inputs = kernel_inputs(s);
  for (std::size_t i = 0; i < gi.z.size(); ++i) inputs.push_back({gi.z[i], "z[" + std::to_string(i) + "]", "z"});
  std::vector<GiNaC::symbol> x(s.q0.begin(), s.q0.end());
  x.insert(x.end(), gi.z.begin(), gi.z.end());
  x.insert(x.end(), s.q1.begin(), s.q1.end());
  const std::size_t E = x.size(), M = gi.z.size(), m = s.q0.size();
  std::vector<ex> grad(E);
  for (std::size_t i = 0; i < E; ++i) grad[i] = gi.action.diff(x[i]);
  std::vector<ex> hess(E * E, 0);
  for (std::size_t i = 0; i < E; ++i) {
    for (std::size_t j = i; j < E; ++j) hess[i * E + j] = hess[j * E + i] = grad[i].diff(x[j]);
  }
  const std::vector<std::string> args = {"h", "t0", "t1", "q0", "q1", "p", "z"};
  std::vector<KernelIR> out;
  // The extended-precision twins of iterative refinement: "interior" and "ext_grad" for the
  // gradient (grad_extended), "ext_full" for models of order >= 2 (full_extended).
  auto add = [&](const std::string& variant, const std::vector<KernelOutput>& outs) {
    KernelIR k;
    k.variant = variant;
    k.function = model.name + "_" + spec.ident + "_" + variant;
    const bool twin = variant == "interior" || variant == "ext_grad" || (variant == "ext_full" && model.order >= 2);
    KernelIR wide;
    k.code = generate_kernel_code(outs, inputs, options, twin ? &wide.code : nullptr);
    k.unused_inputs = unused(k.code, args);
    if (twin) {
      wide.variant = variant + "_extended";
      wide.function = k.function + "_extended";
      wide.unused_inputs = k.unused_inputs;
      extended->push_back(std::move(wide));
    }
    out.push_back(std::move(k));
  };
  std::vector<KernelOutput> outs;
  add_vector(outs, "z", gi.start);
  add("start", outs);
  outs.clear();
  for (std::size_t i = 0; i < M; ++i) outs.push_back({"g[" + std::to_string(i) + "]", grad[m + i]});
  for (std::size_t i = 0; i < M; ++i) {
    for (std::size_t j = 0; j < M; ++j) outs.push_back({"H[" + std::to_string(i * M + j) + "]", hess[(m + i) * E + m + j]});
  }
  add("interior", outs);
  outs.clear();
  outs.push_back({"S[0]", gi.action});
  add_vector(outs, "g", grad);
  add("ext_grad", outs);
  add_vector(outs, "H", hess);
  add("ext_full", outs);
  return out;
}

/** The model whose Lagrangian is `model`'s clock: the same interpolant and quadrature then
 *  integrate the clock over an interval. */
LagModel clock_as_lagrangian(const LagModel& model) {
  LagModel out = model;
  out.lagrangian = model.clock;
  return out;
}

/** The travel kernels of `dir` (DiscretizationIR::travel, travel_interval) of a model with a
 *  clock; where L or the clock depends on t, the time at a quadrature point is linear between the
 *  interval's t0 and t1, as in the discrete Lagrangian. */
void add_travel(const LagModel& model, const KernelSymbols& s, const CseOptions& options, DiscretizationIR& dir) {
  if (!model.has_clock) return;
  const LagModel clock_model = clock_as_lagrangian(model);
  KernelIR k;
  k.variant = "travel";
  k.function = model.name + "_" + dir.spec.ident + "_travel";
  if (dir.spec.interior_points > 0) {
    const GalerkinInterval gi = galerkin_interval(clock_model, dir.spec, s);
    std::vector<KernelInput> inputs = kernel_inputs(s);
    for (std::size_t i = 0; i < gi.z.size(); ++i) inputs.push_back({gi.z[i], "z[" + std::to_string(i) + "]", "z"});
    KernelIR z;
    z.variant = "travel_z";
    z.function = k.function + "_z";
    z.code = generate_kernel_code({{"return", gi.action}}, inputs, options);
    z.unused_inputs = unused(z.code, {"h", "t0", "t1", "q0", "q1", "p", "z"});
    dir.travel_interval = std::move(z);
  } else {
    k.code = generate_kernel_code({{"return", discrete_lagrangian(clock_model, dir.spec, s)}}, kernel_inputs(s), options);
    k.unused_inputs = unused(k.code, {"h", "t0", "t1", "q0", "q1", "p"});
  }
  dir.travel = std::move(k);
}

/** build_model_ir without its translation of GiNaC's arithmetic errors. */
ModelIR build_ir(const LagModel& model, const std::string& source_name, const CseOptions& options) {
  ModelIR ir;
  ir.model = model;
  ir.source_name = source_name;
  KernelSymbols s(model);
  const std::vector<KernelInput> inputs = kernel_inputs(s);
  const std::vector<std::string> args = {"h", "t0", "t1", "q0", "q1", "p"};
  for (const DiscretizationSpec& spec : model.discretizations) {
    DiscretizationIR dir;
    dir.spec = spec;
    if (spec.interior_points > 0) {
      dir.interval_kernels = interval_kernels(model, spec, s, options, &dir.interior_dim, &dir.interval_extended);
      // grad_extended and full_extended: condensation.hpp's condensed_extended over them.
      dir.extended = KernelIR{"grad_extended", model.name + "_" + spec.ident + "_grad_extended", {}, {}};
      if (model.order >= 2)
        dir.extended_full = KernelIR{"full_extended", model.name + "_" + spec.ident + "_full_extended", {}, {}};
      for (const std::string& variant : kernel_variants()) {
        KernelIR k;
        k.variant = variant;
        k.function = model.name + "_" + spec.ident + "_" + variant;
        dir.kernels.push_back(std::move(k));
      }
      add_travel(model, s, options, dir);
      ir.discretizations.push_back(std::move(dir));
      continue;
    }
    Derivatives d = differentiate(discrete_lagrangian(model, spec, s), s);
    for (const std::string& variant : kernel_variants()) {
      std::vector<KernelOutput> outs;
      if (variant == "action") {
        outs.push_back({"return", d.Ld});
      } else {
        if (variant != "sweep") outs.push_back({"Ld[0]", d.Ld});
        add_vector(outs, "D1", d.D1);
        add_vector(outs, "D2", d.D2);
        if (variant != "grad") {
          add_vector(outs, "D11", d.D11);
          if (variant == "full") add_vector(outs, "D12", d.D12);
          add_vector(outs, "D22", d.D22);
        }
      }
      KernelIR k;
      k.variant = variant;
      k.function = model.name + "_" + spec.ident + "_" + variant;
      KernelIR wide;
      // Extended-precision twins: the gradient for every model (the residual of iterative
      // refinement), the Hessian for models of order >= 2 (its corrections at large N).
      const bool extended = variant == "grad" || (variant == "full" && model.order >= 2);
      k.code = generate_kernel_code(outs, inputs, options, extended ? &wide.code : nullptr);
      k.unused_inputs = unused(k.code, args);
      if (extended) {
        wide.variant = variant + "_extended";
        wide.function = k.function + "_extended";
        wide.unused_inputs = k.unused_inputs;
        (variant == "grad" ? dir.extended : dir.extended_full) = std::move(wide);
      }
      dir.kernels.push_back(std::move(k));
    }
    add_travel(model, s, options, dir);
    ir.discretizations.push_back(std::move(dir));
  }
  if (model.has_clock) {
    KernelIR k;
    k.variant = "clock";
    k.function = model.name + "_clock";
    k.code = generate_kernel_code({{"return", interval_clock(model, s)}}, inputs, options);
    k.unused_inputs = unused(k.code, {"h", "t0", "q0", "q1", "p"});
    ir.clock = std::move(k);
  }
  return ir;
}

}  // namespace

ModelIR build_model_ir(const LagModel& model, const std::string& source_name, const CseOptions& options) {
  try {
    return build_ir(model, source_name, options);
  } catch (const std::exception& error) {
    // E.g. a zero base raised to a negative power that appears only in a derivative.
    if (!symbolic_arithmetic_error(error)) throw;
    throw CodegenError(std::string("the Lagrangian or its derivatives cannot be formed: ") + error.what());
  }
}

std::string ir_to_json(const ModelIR& ir) {
  const LagModel& m = ir.model;
  Json j;
  j["format"] = "pardel-ir";
  j["format_version"] = 1;
  j["generator"] = text(std::string("pardel-gen ") + generator_version());
  j["generator_version"] = text(generator_version());
  j["abi_version"] = PARDEL_KERNEL_ABI_VERSION;
  Json& model = j["model"];
  model["name"] = text(m.name);
  model["source"] = text(ir.source_name);
  model["order"] = m.order;
  model["ncoords"] = m.ncoords();
  model["dim"] = m.dim();
  model["coords"] = Json::array();
  for (const std::string& c : m.coords) model["coords"].push_back(text(c));
  model["params"] = Json::array();
  for (const auto& p : m.params) {
    model["params"].push_back(Json{{"name", text(p.name)}, {"default", text(c_double_literal(p.default_value))}});
  }
  model["time_dependent"] = m.time_dependent();
  model["cost"] = m.cost_name.empty() ? Json(nullptr) : Json{{"name", text(m.cost_name)}, {"kind", text(m.cost_kind)}};
  j["discretizations"] = Json::array();
  for (const DiscretizationIR& d : ir.discretizations) {
    Json disc;
    disc["name"] = text(d.spec.name);
    disc["ident"] = text(d.spec.ident);
    disc["consistency_order"] = d.spec.consistency_order;
    disc["bare_name"] = d.spec.bare_name.empty() ? Json(nullptr) : text(d.spec.bare_name);
    disc["interior_dim"] = d.interior_dim;
    disc["kernels"] = Json::array();
    for (const KernelIR& k : d.kernels) disc["kernels"].push_back(kernel_json(k));
    disc["extended_kernel"] = optional_kernel_json(d.extended);
    disc["extended_full_kernel"] = optional_kernel_json(d.extended_full);
    disc["travel_kernel"] = optional_kernel_json(d.travel);
    disc["travel_interval_kernel"] = optional_kernel_json(d.travel_interval);
    disc["interval_kernels"] = Json::array();
    for (const KernelIR& k : d.interval_kernels) disc["interval_kernels"].push_back(kernel_json(k));
    disc["interval_extended_kernels"] = Json::array();
    for (const KernelIR& k : d.interval_extended) disc["interval_extended_kernels"].push_back(kernel_json(k));
    j["discretizations"].push_back(std::move(disc));
  }
  j["clock"] = optional_kernel_json(ir.clock);
  return dump(j);
}

std::string stats_table(const ModelIR& ir) {
  std::ostringstream s;
  char line[256];
  std::snprintf(line, sizeof line, "%-28s %-8s %12s %12s %8s\n", "discretization", "kernel", "ops before", "ops after",
                "ratio");
  s << "model " << ir.model.name << " (" << ir.source_name << ")\n" << line;
  auto row = [&](const std::string& disc, const KernelIR& k) {
    double ratio = k.code.ops_after ? static_cast<double>(k.code.ops_before) / static_cast<double>(k.code.ops_after) : 0.0;
    std::snprintf(line, sizeof line, "%-28s %-8s %12lld %12lld %7.1fx\n", disc.c_str(), k.variant.c_str(),
                  k.code.ops_before, k.code.ops_after, ratio);
    s << line;
  };
  for (const DiscretizationIR& d : ir.discretizations) {
    for (const KernelIR& k : d.kernels) {
      if (d.interior_dim == 0) row(d.spec.name, k);
    }
    for (const KernelIR& k : d.interval_kernels) row(d.spec.name, k);
  }
  if (ir.clock) row("-", *ir.clock);
  return s.str();
}

std::string stats_json(const ModelIR& ir) {
  Json j;
  j["model"] = text(ir.model.name);
  j["source"] = text(ir.source_name);
  j["op_convention"] = "each binary + - * /, each unary minus and each function call is one operation";
  j["kernels"] = Json::array();
  auto row = [&](const std::string& disc, const KernelIR& k) {
    j["kernels"].push_back(Json{{"discretization", text(disc)},
                                {"variant", text(k.variant)},
                                {"function", text(k.function)},
                                {"ops_before_cse", k.code.ops_before},
                                {"ops_after_cse", k.code.ops_after},
                                {"temporaries", k.code.temporaries.size()}});
  };
  for (const DiscretizationIR& d : ir.discretizations) {
    for (const KernelIR& k : d.kernels) {
      if (d.interior_dim == 0) row(d.spec.name, k);
    }
    for (const KernelIR& k : d.interval_kernels) row(d.spec.name, k);
  }
  if (ir.clock) row("", *ir.clock);
  return dump(j);
}

namespace {

/** Whether the model with `lagrangian` as its Lagrangian (and no clock) fails to build. */
bool fails_alone(LagModel& probe, const GiNaC::ex& lagrangian, const std::string& source_name,
                 const CseOptions& options) {
  probe.lagrangian = lagrangian;
  try {
    build_model_ir(probe, source_name, options);
    return false;
  } catch (const CodegenError&) {
    return true;
  }
}

[[noreturn]] void throw_at(const LagModel& model, int line, int col, const std::string& message) {
  const std::string source =
      line >= 1 && line <= static_cast<int>(model.source_lines.size()) ? model.source_lines[line - 1] : "";
  throw LagError(lag_diagnostic(model.filename, source, line, col, message), line, col, message);
}

}  // namespace

ModelIR build_model_ir_located(const LagModel& model, const std::string& source_name, const CseOptions& options) {
  try {
    return build_model_ir(model, source_name, options);
  } catch (const CodegenError& error) {
    if (model.lagrangian_line == 0) throw;  // not from the reader: no positions known
    LagModel probe = model;
    probe.source_lines.clear();
    probe.terms.clear();
    probe.has_clock = false;
    // Each probe runs the whole pipeline on one term: bounded so that a model with very many
    // terms is not probed for minutes (the expression's position is reported then).
    constexpr std::size_t kMaxProbes = 200;
    for (std::size_t i = 0; i < model.terms.size() && i < kMaxProbes; ++i) {
      const SourceTerm& term = model.terms[i];
      if (fails_alone(probe, term.value, source_name, options)) throw_at(model, term.line, term.column, error.what());
    }
    if (!model.has_clock || fails_alone(probe, model.lagrangian, source_name, options))
      throw_at(model, model.lagrangian_line, model.lagrangian_column, error.what());
    throw_at(model, model.clock_line, model.clock_column, error.what());
  }
}

}  // namespace pardel_codegen
