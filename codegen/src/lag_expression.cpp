/**
 * @file lag_expression.cpp
 * The expression parser of the .lag reader: a recursive descent over one line's tokens (sums,
 * products, unary signs, right-associative powers, calls, names and numbers) that builds GiNaC
 * expressions directly, refusing what GiNaC would evaluate at unbounded cost or reject.
 */
#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "lag_reader.hpp"

namespace pardel_codegen::lag {

const std::set<std::string>& unary_functions() {
  static const std::set<std::string> names = {"sin",  "cos",  "tan",  "exp",  "log",  "sqrt",
                                              "sinh", "cosh", "tanh", "asin", "acos", "atan"};
  return names;
}
bool is_function_name(const std::string& s) {
  return unary_functions().count(s) != 0 || s == "atan2" || s == "pow";
}
bool is_reserved_name(const std::string& s) { return s == "t" || s == "pi" || is_function_name(s); }

GiNaC::ex Reader::number_value(const Line& line, const Token& tok) const {
  const std::string& s = tok.text;
  std::size_t epos = s.find_first_of("eE");
  std::string mant = s.substr(0, epos);
  long exponent = 0;
  if (epos != std::string::npos) {
    std::string digits = s.substr(epos + 1);
    const bool negative = !digits.empty() && digits[0] == '-';
    if (!digits.empty() && (digits[0] == '-' || digits[0] == '+')) digits.erase(0, 1);
    digits.erase(0, std::min(digits.find_first_not_of('0'), digits.size()));
    if (digits.size() > 3 || (!digits.empty() && std::stoi(digits) > 308)) {
      fail(line, tok, "number '" + s + "' is out of range");
    }
    exponent = digits.empty() ? 0 : std::stoi(digits);
    if (negative) exponent = -exponent;
  }
  std::size_t dot = mant.find('.');
  std::string digits = mant;
  if (dot != std::string::npos) {
    digits = mant.substr(0, dot) + mant.substr(dot + 1);
    exponent -= static_cast<long>(mant.size() - dot - 1);
  }
  std::size_t nz = digits.find_first_not_of('0');
  digits = nz == std::string::npos ? "0" : digits.substr(nz);
  GiNaC::numeric value(digits.c_str());
  GiNaC::numeric ten(10);
  if (exponent > 0) value = value * ten.power(GiNaC::numeric(exponent));
  if (exponent < 0) value = value / ten.power(GiNaC::numeric(-exponent));
  return value;
}

GiNaC::ex Reader::resolve_identifier(const Line& line, const Token& tok, const ExprContext& ctx) const {
  const std::string& name = tok.text;
  if (ctx.scope == Scope::constant) {
    if (name == "pi" && tok.primes == 0) return GiNaC::Pi;
    fail(line, tok, "expected a number here, found " + tok.shown() + " (defaults are constants)");
  }
  auto coord = coord_index_.find(name);
  if (coord != coord_index_.end()) {
    if (tok.primes > ctx.max_derivative) {
      std::string what = name + std::string(static_cast<std::size_t>(tok.primes), '\'');
      fail(line, tok, what + " is a derivative of order " + std::to_string(tok.primes) + ", but " +
                          ctx.derivative_limit_reason);
    }
    return model_.coord_symbols[static_cast<std::size_t>(tok.primes)][coord->second];
  }
  if (tok.primes > 0) {
    fail(line, tok, "'" + name + "' is not a coordinate; only coordinates take primes (')");
  }
  if (name == "t") return model_.time;
  if (name == "pi") return GiNaC::Pi;
  auto param = param_index_.find(name);
  if (param != param_index_.end()) return model_.params[param->second].symbol;
  auto let = lets_.find(name);
  if (let != lets_.end()) {
    if (let->second.line >= ctx.let_limit_line || !let->second.defined) {
      fail(line, tok, "let '" + name + "' is used before its definition (line " +
                          std::to_string(let->second.line) + ")");
    }
    return let->second.value;
  }
  if (is_function_name(name)) {
    fail(line, tok, "function '" + name + "' needs its arguments in parentheses: " + name + "(...)");
  }
  fail(line, tok, "unknown identifier '" + name + "'");
}

GiNaC::ex Reader::parse_atom(Cursor& c, const ExprContext& ctx) const {
  const Line& line = *c.line;
  const Token& tok = c.peek();
  if (tok.kind == Tok::number) {
    c.next();
    return number_value(line, tok);
  }
  if (tok.kind == Tok::op && tok.text == "(") {
    c.next();
    GiNaC::ex inner = parse_sum(c, ctx);
    if (!c.at_op(')')) fail(line, c.peek(), "expected ')' to close the '(' at column " + std::to_string(tok.col) +
                                                 ", found " + c.peek().shown());
    c.next();
    return inner;
  }
  if (tok.kind == Tok::ident) {
    c.next();
    bool call = c.at_op('(');
    if (call && tok.primes == 0 && is_function_name(tok.text)) {
      const Token& open = c.next();
      std::vector<GiNaC::ex> args;
      if (c.at_op(')')) fail(line, c.peek(), "expected an argument of '" + tok.text + "'");
      for (;;) {
        args.push_back(parse_sum(c, ctx));
        if (c.at_op(',')) {
          c.next();
          continue;
        }
        if (c.at_op(')')) break;
        fail(line, c.peek(), "expected ',' or ')' in the arguments of '" + tok.text + "' (opened at column " +
                                 std::to_string(open.col) + "), found " + c.peek().shown());
      }
      c.next();
      std::size_t want = unary_functions().count(tok.text) ? 1 : 2;
      if (args.size() != want) {
        fail(line, tok, "'" + tok.text + "' takes " + std::to_string(want) + " argument" + (want == 1 ? "" : "s") +
                            ", got " + std::to_string(args.size()));
      }
      const std::string& f = tok.text;
      if (f == "pow") check_power(line, tok, args[0], args[1]);
      if (f == "log" && args[0].is_zero()) fail(line, tok, "log(0) is undefined");
      return term(line, tok.col, guarded(line, tok.col, [&]() -> GiNaC::ex {
        const GiNaC::ex& a = args[0];
        if (f == "sin") return GiNaC::sin(a);
        if (f == "cos") return GiNaC::cos(a);
        if (f == "tan") return GiNaC::tan(a);
        if (f == "exp") return GiNaC::exp(a);
        if (f == "log") return GiNaC::log(a);
        if (f == "sqrt") return GiNaC::sqrt(a);
        if (f == "sinh") return GiNaC::sinh(a);
        if (f == "cosh") return GiNaC::cosh(a);
        if (f == "tanh") return GiNaC::tanh(a);
        if (f == "asin") return GiNaC::asin(a);
        if (f == "acos") return GiNaC::acos(a);
        if (f == "atan") return GiNaC::atan(a);
        if (f == "atan2") return GiNaC::atan2(a, args[1]);
        return GiNaC::pow(a, args[1]);
      }));
    }
    if (call) {
      if (is_function_name(tok.text)) fail(line, tok, "a function name cannot carry primes (')");
      fail(line, tok, "'" + tok.text + "' is not a function (write '*' for a product)");
    }
    return resolve_identifier(line, tok, ctx);
  }
  if (tok.kind == Tok::end) fail(line, tok, "expected an expression at the end of the line");
  fail(line, tok, "expected an expression, found " + tok.shown());
}

/**
 * Refuses powers that GiNaC would evaluate exactly at unbounded cost (2^(10^308)) or that it
 * rejects by throwing after allocating (0^-3, 0^0): all are reported here, before GiNaC sees them.
 */
void Reader::check_power(const Line& line, const Token& op, const GiNaC::ex& base, const GiNaC::ex& exponent) const {
  if (!GiNaC::is_a<GiNaC::numeric>(exponent)) return;
  const GiNaC::numeric& e = GiNaC::ex_to<GiNaC::numeric>(exponent);
  if (GiNaC::is_a<GiNaC::numeric>(base) && GiNaC::ex_to<GiNaC::numeric>(base).is_zero()) {
    if (e.real().is_negative()) fail(line, op, "division by zero: 0 raised to a negative power");
    if (e.real().is_zero()) fail(line, op, "0^0 is undefined");
  }
  if (!GiNaC::is_a<GiNaC::numeric>(base) || !e.is_rational()) return;
  const GiNaC::numeric& b = GiNaC::ex_to<GiNaC::numeric>(base);
  if (!b.is_rational() || b.is_zero() || GiNaC::abs(b) == 1) return;
  // The exact result has about |numerator of e| * (bits of b) bits; keep it within reach.
  const GiNaC::numeric bits = GiNaC::numeric(static_cast<long>(b.numer().int_length() + b.denom().int_length()));
  if (GiNaC::abs(e.numer()) * bits > GiNaC::numeric(1L << 20)) {
    fail(line, op, "exponent is too large for an exact power of a number");
  }
}

GiNaC::ex Reader::parse_power(Cursor& c, const ExprContext& ctx) const {
  GiNaC::ex base = parse_atom(c, ctx);
  if (c.at_op('^')) {
    const Token& op = c.next();
    GiNaC::ex exponent = parse_unary(c, ctx);  // right-associative; allows x^-1
    check_power(*c.line, op, base, exponent);
    return term(*c.line, op.col, guarded(*c.line, op.col, [&] { return GiNaC::pow(base, exponent); }));
  }
  return base;
}

/** Deeper expressions are rejected rather than risking the stack (here or in GiNaC). */
constexpr int kMaxNesting = 200;

GiNaC::ex Reader::parse_unary(Cursor& c, const ExprContext& ctx) const {
  struct Depth {
    int& d;
    explicit Depth(int& v) : d(v) { ++d; }
    ~Depth() { --d; }
  } depth(c.depth);
  if (c.depth > kMaxNesting) {
    fail(*c.line, c.peek(), "expression is nested too deeply (at most " + std::to_string(kMaxNesting) + " levels)");
  }
  if (c.at_op('-')) {
    c.next();
    return -parse_unary(c, ctx);
  }
  if (c.at_op('+')) {
    c.next();
    return parse_unary(c, ctx);
  }
  return parse_power(c, ctx);
}

GiNaC::ex Reader::parse_product(Cursor& c, const ExprContext& ctx) const {
  GiNaC::ex acc = parse_unary(c, ctx);
  while (c.at_op('*') || c.at_op('/')) {
    const Token& op = c.next();
    GiNaC::ex rhs = parse_unary(c, ctx);
    if (op.text == "*") {
      acc = acc * rhs;
    } else {
      if (rhs.is_zero()) fail(*c.line, op, "division by zero");
      acc = guarded(*c.line, op.col, [&] { return acc / rhs; });
    }
  }
  return acc;
}

GiNaC::ex Reader::parse_sum(Cursor& c, const ExprContext& ctx) const {
  GiNaC::ex acc = parse_product(c, ctx);
  while (c.at_op('+') || c.at_op('-')) {
    const Token& op = c.next();
    GiNaC::ex rhs = parse_product(c, ctx);
    acc = (op.text == "+") ? acc + rhs : acc - rhs;
  }
  return acc;
}

GiNaC::ex Reader::parse_expression(Cursor& c, const ExprContext& ctx) const { return parse_sum(c, ctx); }

namespace {

/** The largest number of nodes an expression may have as a tree, its lets written out: GiNaC
 *  shares a let used twice, but differentiation and the discretization walk the tree, so a chain of
 *  lets that each use the one before twice costs time and memory exponential in its length (23
 *  lines ran for minutes into gigabytes; 3.9 s at 3.3e4 nodes, 18.6 s at 1.3e5). The bundled models
 *  stay below 1,000. */
constexpr double kMaxTreeSize = 5e4;

/** The number of nodes of `e` as a tree, counted once per shared subexpression (memo), stopping
 *  once it exceeds kMaxTreeSize. */
double tree_size(const GiNaC::ex& e, std::map<GiNaC::ex, double, GiNaC::ex_is_less>& memo) {
  if (const auto it = memo.find(e); it != memo.end()) return it->second;
  double size = 1;
  for (std::size_t i = 0; i < e.nops() && size <= kMaxTreeSize; ++i) size += tree_size(e.op(i), memo);
  memo.emplace(e, size);
  return size;
}

}  // namespace

GiNaC::ex Reader::parse_full_expression(const Line& line, std::size_t pos, const ExprContext& ctx) const {
  Cursor c{&line, pos};
  GiNaC::ex value = parse_expression(c, ctx);
  const Token& rest = c.peek();
  if (rest.kind != Tok::end) {
    if (rest.kind == Tok::op && rest.text == ")") fail(line, rest, "unmatched ')'");
    fail(line, rest, "expected an operator or the end of the line, found " + rest.shown());
  }
  std::map<GiNaC::ex, double, GiNaC::ex_is_less> memo;
  if (tree_size(value, memo) > kMaxTreeSize)
    fail(line, line.tokens[pos],
         "the expression, its lets written out, has more than " + std::to_string(static_cast<long>(kMaxTreeSize)) +
             " terms (a chain of lets that each use the one before more than once doubles it at every step); "
             "differentiating it would take too long");
  return value;
}

}  // namespace pardel_codegen::lag
