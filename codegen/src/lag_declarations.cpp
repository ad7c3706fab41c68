/**
 * @file lag_declarations.cpp
 * The declaration lines of the .lag reader (model, order, coords, param, let, L, clock, cost and
 * discretizations): each is checked and recorded when it is read; the expressions of lets, L and
 * clock are parsed afterwards by Reader::read, once every name is known.
 */
#include <cmath>
#include <string>
#include <vector>

#include "lag_reader.hpp"
#include "pardel_codegen/cse.hpp"

namespace pardel_codegen::lag {

void Reader::declare_name(const Line& line, const Token& tok, const char* what) {
  if (tok.kind != Tok::ident) {
    fail(line, tok, std::string("expected a ") + what + " name (a C identifier), found " + tok.shown());
  }
  if (tok.primes > 0) fail(line, tok, std::string("a ") + what + " name cannot carry primes (')");
  if (is_reserved_name(tok.text)) {
    fail(line, tok, "'" + tok.text + "' is reserved (t, pi and function names cannot be redefined)");
  }
  auto it = names_.find(tok.text);
  if (it != names_.end()) {
    fail(line, tok, "duplicate name '" + tok.text + "' (already declared as a " + it->second.kind +
                        " at line " + std::to_string(it->second.line) + ")");
  }
  names_[tok.text] = NameInfo{what, line.number};
}

void Reader::expect_end(const Line& line, std::size_t pos, const char* after) const {
  const Token& tok = line.tokens[pos];
  if (tok.kind != Tok::end) fail(line, tok, "unexpected " + tok.shown() + " after " + after);
}

void Reader::read_declaration(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  const Token& head = toks[0];
  const std::string keywords = "model, order, coords, param, let, L, clock, cost or discretizations";
  if (head.kind != Tok::ident || head.primes > 0) {
    fail(line, head, "expected a declaration (" + keywords + "), found " + head.shown());
  }
  const std::string& kw = head.text;
  if (kw == "model") {
    read_model(line);
  } else if (kw == "order") {
    read_order(line);
  } else if (kw == "coords") {
    read_coords(line);
  } else if (kw == "param") {
    read_param(line);
  } else if (kw == "let") {
    read_let(line);
  } else if (kw == "L" || kw == "clock") {
    read_equation(line);
  } else if (kw == "cost") {
    read_cost(line);
  } else if (kw == "discretizations") {
    if (discretization_line_) {
      fail(line, head, "duplicate 'discretizations' line (first at line " +
                           std::to_string(discretization_line_->number) + ")");
    }
    if (toks[1].kind == Tok::end) fail(line, toks[1], "expected at least one discretization name");
    discretization_line_ = line;
  } else {
    fail(line, head, "expected a declaration (" + keywords + "), found " + head.shown());
  }
}

/** `model NAME`. */
void Reader::read_model(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  const Token& head = toks[0];
  if (model_line_ != 0) fail(line, head, "duplicate 'model' line (first at line " + std::to_string(model_line_) + ")");
  const Token& name = toks[1];
  if (name.kind != Tok::ident || name.primes > 0) {
    fail(line, name, "expected a model name (a C identifier: letters, digits, '_'), found " + name.shown());
  }
  if (name.text[0] == '_') fail(line, name, "a model name must start with a letter");
  if (name.text == "pardel" || name.text.rfind("pardel_", 0) == 0) {
    fail(line, name, "model names 'pardel' and 'pardel_...' are reserved for pardel's own symbols");
  }
  if (name.text.size() > kMaxModelNameLength) {
    fail(line, name, "model name is too long (at most " + std::to_string(kMaxModelNameLength) + " characters)");
  }
  expect_end(line, 2, "the model name");
  model_.name = name.text;
  model_line_ = line.number;
}

/** `order N`, N from 1 to 9. */
void Reader::read_order(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  const Token& head = toks[0];
  if (order_line_ != 0) fail(line, head, "duplicate 'order' line (first at line " + std::to_string(order_line_) + ")");
  const Token& n = toks[1];
  bool digits = n.kind == Tok::number && n.text.find_first_not_of("0123456789") == std::string::npos;
  if (!digits || n.text.size() > 2 || std::stoi(n.text) < 1 || std::stoi(n.text) > 9) {
    fail(line, n, "expected the order as an integer from 1 to 9, found " + n.shown());
  }
  expect_end(line, 2, "the order");
  model_.order = std::stoi(n.text);
  order_line_ = line.number;
}

/** `coords NAME...`: the generalized coordinates. */
void Reader::read_coords(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  const Token& head = toks[0];
  if (coords_line_ != 0) fail(line, head, "duplicate 'coords' line (first at line " + std::to_string(coords_line_) + ")");
  if (toks[1].kind == Tok::end) fail(line, toks[1], "expected at least one coordinate name");
  for (std::size_t i = 1; toks[i].kind != Tok::end; ++i) {
    declare_name(line, toks[i], "coordinate");
    coord_index_[toks[i].text] = model_.coords.size();
    model_.coords.push_back(toks[i].text);
  }
  coords_line_ = line.number;
}

/** `param NAME = DEFAULT`, the default a constant expression. */
void Reader::read_param(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  declare_name(line, toks[1], "param");
  if (!(toks[2].kind == Tok::op && toks[2].text == "=")) {
    fail(line, toks[2], "expected '=' and a default value after the param name, found " + toks[2].shown());
  }
  ExprContext ctx;
  ctx.scope = Scope::constant;
  GiNaC::ex value = parse_full_expression(line, 3, ctx);
  GiNaC::ex num;
  if (has_huge_number(value)) fail(line, toks[3], "the default of param '" + toks[1].text + "' is beyond 1e300 in magnitude");
  try {
    num = value.evalf();
  } catch (const std::exception&) {
    num = value;
  }
  // cln converts values beyond the range of double without notice: check the range first.
  if (!GiNaC::is_a<GiNaC::numeric>(num) || !GiNaC::ex_to<GiNaC::numeric>(num).is_real() ||
      GiNaC::abs(GiNaC::ex_to<GiNaC::numeric>(num)) > GiNaC::numeric(1.7976931348623157e308) ||
      !std::isfinite(GiNaC::ex_to<GiNaC::numeric>(num).to_double())) {
    fail(line, toks[3], "the default of param '" + toks[1].text + "' is not a finite real number");
  }
  ParamDecl p;
  p.name = toks[1].text;
  p.default_value = GiNaC::ex_to<GiNaC::numeric>(num).to_double();
  p.symbol = GiNaC::symbol(p.name);
  param_index_[p.name] = model_.params.size();
  model_.params.push_back(p);
}

/** `let NAME = EXPRESSION`: the expression is parsed once every name is known. */
void Reader::read_let(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  declare_name(line, toks[1], "let");
  if (!(toks[2].kind == Tok::op && toks[2].text == "=")) {
    fail(line, toks[2], "expected '=' after the let name, found " + toks[2].shown());
  }
  lets_[toks[1].text] = LetDecl{toks[1].text, line.number, GiNaC::ex(), false};
  let_lines_.push_back(line);
}

/** `L = EXPRESSION` or `clock = EXPRESSION`: the expression is parsed once every name is known. */
void Reader::read_equation(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  const Token& head = toks[0];
  const std::string& kw = head.text;
  std::optional<Line>& slot = (kw == "L") ? lagrangian_line_ : clock_line_;
  if (!(toks[1].kind == Tok::op && toks[1].text == "=")) {
    fail(line, toks[1], "expected '=' after '" + kw + "', found " + toks[1].shown());
  }
  if (slot) {
    fail(line, head, "duplicate '" + kw + "' (first defined at line " + std::to_string(slot->number) + ")");
  }
  slot = line;
}

/** `cost NAME = action` or `cost NAME = clock`. */
void Reader::read_cost(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  const Token& head = toks[0];
  if (cost_line_) fail(line, head, "duplicate 'cost' line (first at line " + std::to_string(cost_line_->number) + ")");
  const Token& name = toks[1];
  if (name.kind != Tok::ident || name.primes > 0) {
    fail(line, name, "expected the name of the cost (a C identifier, e.g. fuel), found " + name.shown());
  }
  if (name.text.size() > kMaxModelNameLength) {
    fail(line, name, "cost name is too long (at most " + std::to_string(kMaxModelNameLength) + " characters)");
  }
  if (!(toks[2].kind == Tok::op && toks[2].text == "=")) {
    fail(line, toks[2], "expected '=' after the cost name, found " + toks[2].shown());
  }
  const Token& kind = toks[3];
  if (kind.kind != Tok::ident || kind.primes > 0 || (kind.text != "action" && kind.text != "clock")) {
    fail(line, kind,
         "expected 'action' (the cost is the discrete action) or 'clock' (the summed clock), found " + kind.shown());
  }
  expect_end(line, 4, "the cost");
  model_.cost_name = name.text;
  model_.cost_kind = kind.text;
  model_.cost_line = line.number;
  cost_line_ = line;
}

}  // namespace pardel_codegen::lag
