/**
 * @file lag_discretizations.cpp
 * The 'discretizations' line of the .lag reader: the names of the discrete Lagrangians to
 * generate, with their parameters (NAME(KEY=VALUE)), checked against the model's order and turned
 * into canonical DiscretizationSpecs. The names, parameters, ranges and defaults are the rows of
 * the catalogue (discretizations.hpp).
 */
#include <map>
#include <string>
#include <vector>

#include "lag_reader.hpp"
#include "pardel_codegen/discretizations.hpp"

namespace pardel_codegen::lag {

void Reader::read_discretizations(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  std::map<std::string, int> seen;
  std::size_t i = 1;
  while (toks[i].kind != Tok::end) {
    if (toks[i].kind == Tok::op && toks[i].text == ",") {
      ++i;
      continue;
    }
    const Token& name = toks[i];
    if (name.kind != Tok::ident || name.primes > 0) {
      fail(line, name, "expected a discretization name, found " + name.shown());
    }
    ++i;
    bool has_value = false;
    GiNaC::numeric value = 1;
    int value_col = name.col;
    if (toks[i].kind == Tok::op && toks[i].text == "(") {
      value = read_discretization_parameter(line, name, i, value_col);
      has_value = true;
    }
    DiscretizationSpec spec = discretization_spec(line, name, has_value, value, value_col);
    auto it = seen.find(spec.name);
    if (it != seen.end()) {
      fail(line, name, "duplicate discretization '" + spec.name + "'");
    }
    seen[spec.name] = name.col;
    model_.discretizations.push_back(spec);
  }
}

/**
 * The parameter of a discretization, `(KEY=VALUE)`, from the '(' at `i`; leaves `i` after the ')'
 * and `value_col` at the value's column. The key and the value are checked against the first row
 * of the catalogue with this name that takes a parameter, whatever the model's order.
 */
GiNaC::numeric Reader::read_discretization_parameter(const Line& line, const Token& name, std::size_t& i,
                                                     int& value_col) const {
  const std::vector<Token>& toks = line.tokens;
  ++i;
  const Token& key = toks[i];
  if (key.kind != Tok::ident || key.primes > 0) {
    fail(line, key, "expected a parameter name such as alpha, found " + key.shown());
  }
  const DiscretizationFamily* family = parameterized_discretization_family(name.text);
  if (family == nullptr) fail(line, key, "'" + name.text + "' takes no parameters");
  if (key.text != family->parameter.key) {
    fail(line, key, "unknown parameter '" + key.text + "' of " + name.text + " (expected " +
                        family->parameter.expected + ")");
  }
  ++i;
  if (!(toks[i].kind == Tok::op && toks[i].text == "=")) {
    fail(line, toks[i], "expected '=' after " + key.text + ", found " + toks[i].shown());
  }
  ++i;
  value_col = toks[i].col;
  // The value: an optionally signed rational number, up to the closing parenthesis.
  Cursor c{&line, i};
  ExprContext ctx;
  ctx.scope = Scope::constant;
  GiNaC::ex parsed = parse_sum(c, ctx);
  if (!c.at_op(')')) fail(line, c.peek(), "expected ')' after the value of " + key.text + ", found " + c.peek().shown());
  i = c.pos + 1;
  const std::string refusal = family->parameter.refusal(name.text, parsed, model_.order);
  if (!refusal.empty()) fail(line.number, value_col, refusal);
  return GiNaC::ex_to<GiNaC::numeric>(parsed);
}

/** The canonical spec of the discretization `name` (with its parameter `value` when `has_value`). */
DiscretizationSpec Reader::discretization_spec(const Line& line, const Token& name, bool has_value,
                                               const GiNaC::numeric& value, int value_col) const {
  const std::string order = std::to_string(model_.order);
  const DiscretizationFamily* family = find_discretization_family(name.text, model_.order);
  if (family == nullptr) {
    const std::string available = discretization_names(model_.order);
    if (is_discretization_name(name.text)) {
      fail(line, name, "'" + name.text + "' is not available for order-" + order + " models (available: " +
                           available + ")");
    }
    fail(line, name, "unknown discretization '" + name.text + "' (available for order-" + order +
                         " models: " + available + ")");
  }
  const DiscretizationParameter& p = family->parameter;
  if (p.kind == ParameterKind::none) {
    if (has_value) {
      // Another row of the same name takes it (the parameter was read against that row).
      const DiscretizationFamily* other = parameterized_discretization_family(name.text);
      fail(line.number, value_col,
           "'" + name.text + "' takes no parameters for order-" + order + " models (" + other->parameter.key +
               " is for order " + std::to_string(other->min_order) +
               (other->max_order == other->min_order ? std::string() : " and above") + ")");
    }
    return make_discretization_spec(*family, model_.order, 0);
  }
  if (!has_value && p.required) {
    fail(line, name, name.text + " needs its parameter " + p.key + ", e.g. " + name.text + "(" + p.key + "=" +
                         p.example + ") (" + p.meaning + ")");
  }
  return make_discretization_spec(*family, model_.order, has_value ? value : default_parameter(*family, model_.order));
}

}  // namespace pardel_codegen::lag
