/**
 * @file lag_parser.cpp
 * The .lag reader: a line-oriented declaration reader and a recursive-descent expression parser
 * that builds GiNaC expressions directly (primes such as x'' are part of the identifier token,
 * so every diagnostic column refers to the original line). Declarations are read first, so
 * params and coordinates may appear in any order; lets must be defined before they are used.
 */
#include "pardel_codegen/lag_parser.hpp"

#include <cctype>
#include <cstring>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>

#include "pardel/regular_file.hpp"

namespace pardel_codegen {
namespace {

const std::set<std::string>& unary_functions() {
  static const std::set<std::string> names = {"sin",  "cos",  "tan",  "exp",  "log",  "sqrt",
                                              "sinh", "cosh", "tanh", "asin", "acos", "atan"};
  return names;
}
bool is_function_name(const std::string& s) {
  return unary_functions().count(s) != 0 || s == "atan2" || s == "pow";
}
bool is_reserved_name(const std::string& s) { return s == "t" || s == "pi" || is_function_name(s); }
bool has_huge_number(const GiNaC::ex& e);

enum class Tok { ident, number, op, end };

struct Token {
  Tok kind = Tok::end;
  std::string text;  ///< identifier without primes, number text, or the operator character
  int primes = 0;    ///< for identifiers: how many ' follow
  int col = 0;       ///< 1-based byte column in the original line
  std::string shown() const {
    if (kind == Tok::end) return "end of line";
    return "'" + text + std::string(static_cast<std::size_t>(primes), '\'') + "'";
  }
};

/** One source line with its tokens (comment and line ending removed). */
struct Line {
  int number = 0;
  std::string text;  ///< the line as written, without the line ending
  std::vector<Token> tokens;
  int end_col = 1;   ///< column just after the last non-blank character before any comment
};

class Reader {
 public:
  Reader(const std::string& text, std::string filename) : filename_(std::move(filename)) {
    split_lines(text);
  }

  LagModel read();

 private:
  [[noreturn]] void fail(int line, int col, const std::string& message) const {
    std::string source;
    if (line >= 1 && line <= static_cast<int>(raw_lines_.size())) source = raw_lines_[line - 1];
    throw LagError(lag_diagnostic(filename_, source, line, col, message), line, col, message);
  }
  [[noreturn]] void fail(const Line& l, const Token& t, const std::string& message) const {
    fail(l.number, t.kind == Tok::end ? l.end_col : t.col, message);
  }

  void split_lines(const std::string& text) {
    std::size_t start = 0;
    while (start <= text.size()) {
      std::size_t nl = text.find('\n', start);
      std::string line = text.substr(start, nl == std::string::npos ? std::string::npos : nl - start);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      raw_lines_.push_back(line);
      if (nl == std::string::npos) break;
      start = nl + 1;
    }
    if (!raw_lines_.empty() && raw_lines_.back().empty() && !text.empty() && text.back() == '\n') {
      raw_lines_.pop_back();
    }
  }

  Line tokenize(int number) const;
  void read_declaration(const Line& line);
  void read_discretizations(const Line& line);
  void declare_name(const Line& line, const Token& tok, const char* what);

  // Expression parsing over one line's tokens.
  struct Cursor {
    const Line* line;
    std::size_t pos;
    int depth = 0;  ///< nesting of unary operators, powers, parentheses and calls
    const Token& peek() const { return line->tokens[pos]; }
    const Token& next() { return line->tokens[pos++]; }
    bool at_op(char c) const { return peek().kind == Tok::op && peek().text[0] == c; }
  };
  enum class Scope { model, constant };
  struct ExprContext {
    Scope scope = Scope::model;
    int max_derivative = 0;          ///< highest derivative order allowed
    const char* derivative_limit_reason = "";
    int let_limit_line = 0;          ///< lets defined strictly before this line are visible
  };
  GiNaC::ex parse_expression(Cursor& c, const ExprContext& ctx) const;
  GiNaC::ex parse_sum(Cursor& c, const ExprContext& ctx) const;
  GiNaC::ex parse_product(Cursor& c, const ExprContext& ctx) const;
  GiNaC::ex parse_unary(Cursor& c, const ExprContext& ctx) const;
  GiNaC::ex parse_power(Cursor& c, const ExprContext& ctx) const;
  GiNaC::ex parse_atom(Cursor& c, const ExprContext& ctx) const;
  GiNaC::ex resolve_identifier(const Line& line, const Token& tok, const ExprContext& ctx) const;
  GiNaC::ex number_value(const Line& line, const Token& tok) const;
  void check_power(const Line& line, const Token& op, const GiNaC::ex& base, const GiNaC::ex& exponent) const;
  GiNaC::ex parse_full_expression(const Line& line, std::size_t pos, const ExprContext& ctx) const;
  /** Applies a GiNaC operation, turning its exceptions (division by zero, log(0)) into errors. */
  template <class F>
  GiNaC::ex guarded(const Line& line, int col, F&& f) const {
    try {
      return f();
    } catch (const std::exception& e) {
      fail(line.number, col, std::string("cannot evaluate this operation: ") + e.what());
    }
  }

  /** Records a power or call node for diagnostics after parsing (LagModel::terms). */
  GiNaC::ex term(const Line& line, int col, GiNaC::ex value) const {
    terms_.push_back(SourceTerm{line.number, col, value});
    return value;
  }

  std::string filename_;
  std::vector<std::string> raw_lines_;
  LagModel model_;
  mutable std::vector<SourceTerm> terms_;

  struct NameInfo {
    std::string kind;  ///< "coordinate", "param", "let"
    int line = 0;
  };
  std::map<std::string, NameInfo> names_;
  std::map<std::string, std::size_t> coord_index_;
  std::map<std::string, std::size_t> param_index_;
  struct LetDecl {
    std::string name;
    int line = 0;
    GiNaC::ex value;
    bool defined = false;
  };
  std::map<std::string, LetDecl> lets_;
  std::vector<Line> let_lines_;
  std::optional<Line> lagrangian_line_;
  std::optional<Line> clock_line_;
  std::optional<Line> discretization_line_;
  std::optional<Line> cost_line_;
  int model_line_ = 0;
  int order_line_ = 0;
  int coords_line_ = 0;
};

Line Reader::tokenize(int number) const {
  Line l;
  l.number = number;
  l.text = raw_lines_[number - 1];
  const std::string& s = l.text;
  std::size_t i = 0;
  int last_end = 0;
  while (i < s.size()) {
    unsigned char c = static_cast<unsigned char>(s[i]);
    if (c == '#') break;
    if (c == ' ' || c == '\t') {
      ++i;
      continue;
    }
    Token t;
    t.col = static_cast<int>(i) + 1;
    if (std::isalpha(c) || c == '_') {
      std::size_t j = i;
      while (j < s.size() && (std::isalnum(static_cast<unsigned char>(s[j])) || s[j] == '_')) ++j;
      t.kind = Tok::ident;
      t.text = s.substr(i, j - i);
      if (t.text.size() > kMaxIdentifierLength) {
        fail(number, t.col,
             "identifier is too long (at most " + std::to_string(kMaxIdentifierLength) + " characters)");
      }
      while (j < s.size() && s[j] == '\'') {
        ++t.primes;
        ++j;
      }
      i = j;
    } else if (std::isdigit(c) || (c == '.' && i + 1 < s.size() && std::isdigit(static_cast<unsigned char>(s[i + 1])))) {
      std::size_t j = i;
      int dots = 0;
      while (j < s.size() && (std::isdigit(static_cast<unsigned char>(s[j])) || s[j] == '.')) {
        if (s[j] == '.') ++dots;
        ++j;
      }
      if (j < s.size() && (s[j] == 'e' || s[j] == 'E')) {
        std::size_t k = j + 1;
        if (k < s.size() && (s[k] == '+' || s[k] == '-')) ++k;
        if (k < s.size() && std::isdigit(static_cast<unsigned char>(s[k]))) {
          while (k < s.size() && std::isdigit(static_cast<unsigned char>(s[k]))) ++k;
          j = k;
        }
      }
      t.kind = Tok::number;
      t.text = s.substr(i, j - i);
      if (dots > 1) fail(number, t.col, "malformed number '" + t.text + "'");
      if (t.text.size() > 40) fail(number, t.col, "number is too long (at most 40 characters)");
      if (j < s.size() && (std::isalpha(static_cast<unsigned char>(s[j])) || s[j] == '_')) {
        std::size_t k = j;
        while (k < s.size() && (std::isalnum(static_cast<unsigned char>(s[k])) || s[k] == '_')) ++k;
        fail(number, t.col,
             "'" + s.substr(i, k - i) + "' is neither a number nor a name (names start with a letter; "
             "write 2*x for a product)");
      }
      i = j;
    } else if (std::strchr("+-*/^(),=", static_cast<int>(c)) != nullptr && c != 0) {
      t.kind = Tok::op;
      t.text = std::string(1, static_cast<char>(c));
      ++i;
    } else if (c == '\'') {
      fail(number, t.col, "a prime (') must follow a coordinate name");
    } else {
      std::ostringstream msg;
      if (s.compare(i, 3, "\xef\xbb\xbf") == 0) {
        msg << "unexpected byte-order mark (U+FEFF; only allowed as the first bytes of the file)";
      } else if (c == '\r') {
        msg << "carriage return without a line feed (lines must end with LF or CR LF)";
      } else if (c >= 0x20 && c < 0x7f) {
        msg << "unexpected character '" << static_cast<char>(c) << "'";
      } else {
        msg << "unexpected byte 0x" << std::hex << static_cast<int>(c);
      }
      fail(number, t.col, msg.str());
    }
    last_end = static_cast<int>(i);
    l.tokens.push_back(t);
  }
  Token end;
  end.kind = Tok::end;
  end.col = last_end + 1;
  l.end_col = last_end + 1;
  l.tokens.push_back(end);
  return l;
}

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

void Reader::read_declaration(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  const Token& head = toks[0];
  auto expect_end = [&](std::size_t pos, const char* after) {
    if (toks[pos].kind != Tok::end) fail(line, toks[pos], "unexpected " + toks[pos].shown() + " after " + after);
  };
  const std::string keywords = "model, order, coords, param, let, L, clock, cost or discretizations";
  if (head.kind != Tok::ident || head.primes > 0) {
    fail(line, head, "expected a declaration (" + keywords + "), found " + head.shown());
  }
  const std::string& kw = head.text;
  if (kw == "model") {
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
    expect_end(2, "the model name");
    model_.name = name.text;
    model_line_ = line.number;
  } else if (kw == "order") {
    if (order_line_ != 0) fail(line, head, "duplicate 'order' line (first at line " + std::to_string(order_line_) + ")");
    const Token& n = toks[1];
    bool digits = n.kind == Tok::number && n.text.find_first_not_of("0123456789") == std::string::npos;
    if (!digits || n.text.size() > 2 || std::stoi(n.text) < 1 || std::stoi(n.text) > 9) {
      fail(line, n, "expected the order as an integer from 1 to 9, found " + n.shown());
    }
    expect_end(2, "the order");
    model_.order = std::stoi(n.text);
    order_line_ = line.number;
  } else if (kw == "coords") {
    if (coords_line_ != 0) fail(line, head, "duplicate 'coords' line (first at line " + std::to_string(coords_line_) + ")");
    if (toks[1].kind == Tok::end) fail(line, toks[1], "expected at least one coordinate name");
    for (std::size_t i = 1; toks[i].kind != Tok::end; ++i) {
      declare_name(line, toks[i], "coordinate");
      coord_index_[toks[i].text] = model_.coords.size();
      model_.coords.push_back(toks[i].text);
    }
    coords_line_ = line.number;
  } else if (kw == "param") {
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
  } else if (kw == "let") {
    declare_name(line, toks[1], "let");
    if (!(toks[2].kind == Tok::op && toks[2].text == "=")) {
      fail(line, toks[2], "expected '=' after the let name, found " + toks[2].shown());
    }
    lets_[toks[1].text] = LetDecl{toks[1].text, line.number, GiNaC::ex(), false};
    let_lines_.push_back(line);
  } else if (kw == "L" || kw == "clock") {
    std::optional<Line>& slot = (kw == "L") ? lagrangian_line_ : clock_line_;
    if (!(toks[1].kind == Tok::op && toks[1].text == "=")) {
      fail(line, toks[1], "expected '=' after '" + kw + "', found " + toks[1].shown());
    }
    if (slot) {
      fail(line, head, "duplicate '" + kw + "' (first defined at line " + std::to_string(slot->number) + ")");
    }
    slot = line;
  } else if (kw == "cost") {
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
    expect_end(4, "the cost");
    model_.cost_name = name.text;
    model_.cost_kind = kind.text;
    model_.cost_line = line.number;
    cost_line_ = line;
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

/** True when a number in `e` is beyond 1e300 in magnitude (GiNaC's evalf of functions of such
 *  numbers is unreliable: exp(10^308) evaluates to 1.0). */
bool has_huge_number(const GiNaC::ex& e) {
  if (GiNaC::is_a<GiNaC::numeric>(e)) return GiNaC::abs(GiNaC::ex_to<GiNaC::numeric>(e)) > GiNaC::numeric(1e300);
  for (std::size_t i = 0; i < e.nops(); ++i) {
    if (has_huge_number(e.op(i))) return true;
  }
  return false;
}

std::string rational_text(const GiNaC::numeric& n) {
  std::ostringstream s;
  s << n;
  return s.str();
}

/** The largest number of Gauss points hermite_gauss accepts. */
constexpr int kMaxGaussPoints = 16;

/** hermite_gauss(s=S) for an order-`order` model (S >= order): consistency order min(2 order, 2 S). */
DiscretizationSpec hermite_gauss_spec(int order, int stages) {
  DiscretizationSpec spec;
  spec.kind = DiscretizationKind::hermite_gauss;
  spec.stages = stages;
  spec.name = "hermite_gauss(s=" + std::to_string(stages) + ")";
  spec.ident = "hermite_gauss_s_" + std::to_string(stages);
  spec.consistency_order = 2 * std::min(order, stages);
  return spec;
}

/** galerkin_gauss(s=S) or galerkin_lobatto(s=S) for an order-`order` model (S >= order): the
 *  polynomial of degree S + order - 1 through both nodes' jets and S - order interior values,
 *  consistency order 2 S. */
DiscretizationSpec galerkin_spec(DiscretizationKind kind, int order, int stages) {
  DiscretizationSpec spec;
  spec.kind = kind;
  spec.stages = stages;
  spec.interior_points = stages - order;
  const std::string family = kind == DiscretizationKind::galerkin_gauss ? "galerkin_gauss" : "galerkin_lobatto";
  spec.name = family + "(s=" + std::to_string(stages) + ")";
  spec.ident = family + "_s_" + std::to_string(stages);
  spec.consistency_order = 2 * stages;
  return spec;
}

std::string rational_ident(const GiNaC::numeric& n) {
  std::string out;
  for (char c : rational_text(n)) {
    if (c == '-') out += 'm';
    else if (c == '/') out += '_';
    else out += c;
  }
  return out;
}

void Reader::read_discretizations(const Line& line) {
  const std::vector<Token>& toks = line.tokens;
  std::map<std::string, int> seen;
  const std::string galerkin = ", galerkin_gauss(s=S), galerkin_lobatto(s=S)";
  const std::string available = (model_.order == 1   ? "trapezoid, midpoint, hermite_gauss(s=S)"
                                 : model_.order == 2 ? "trapezoid(alpha=A), gauss2, hermite_gauss(s=S)"
                                                     : "hermite_gauss(s=S)") +
                                galerkin;
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
      ++i;
      const Token& key = toks[i];
      if (key.kind != Tok::ident || key.primes > 0) {
        fail(line, key, "expected a parameter name such as alpha, found " + key.shown());
      }
      const bool trapezoid = name.text == "trapezoid", hermite = name.text == "hermite_gauss";
      const bool galerkin_name = name.text == "galerkin_gauss" || name.text == "galerkin_lobatto";
      if (!(trapezoid && key.text == "alpha") && !((hermite || galerkin_name) && key.text == "s")) {
        if (trapezoid) fail(line, key, "unknown parameter '" + key.text + "' of trapezoid (expected alpha)");
        if (hermite) fail(line, key, "unknown parameter '" + key.text + "' of hermite_gauss (expected s, the number of Gauss points)");
        if (galerkin_name)
          fail(line, key, "unknown parameter '" + key.text + "' of " + name.text + " (expected s, half the consistency order)");
        fail(line, key, "'" + name.text + "' takes no parameters");
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
      if (!GiNaC::is_a<GiNaC::numeric>(parsed) || !GiNaC::ex_to<GiNaC::numeric>(parsed).is_rational()) {
        if (trapezoid) fail(line.number, value_col, "alpha must be a rational number such as 1, 1/2 or 0.25");
      }
      if (hermite && (!GiNaC::is_a<GiNaC::numeric>(parsed) || !GiNaC::ex_to<GiNaC::numeric>(parsed).is_integer() ||
                      GiNaC::ex_to<GiNaC::numeric>(parsed) < 1 || GiNaC::ex_to<GiNaC::numeric>(parsed) > kMaxGaussPoints)) {
        fail(line.number, value_col,
             "s (the number of Gauss points) must be an integer from 1 to " + std::to_string(kMaxGaussPoints));
      }
      if (galerkin_name && (!GiNaC::is_a<GiNaC::numeric>(parsed) || !GiNaC::ex_to<GiNaC::numeric>(parsed).is_integer() ||
                            GiNaC::ex_to<GiNaC::numeric>(parsed) < model_.order ||
                            GiNaC::ex_to<GiNaC::numeric>(parsed) > kMaxGaussPoints)) {
        fail(line.number, value_col,
             "s of " + name.text + " must be an integer from " + std::to_string(model_.order) + " (the model's order) to " +
                 std::to_string(kMaxGaussPoints) + "; the consistency order is 2 s");
      }
      value = GiNaC::ex_to<GiNaC::numeric>(parsed);
      has_value = true;
    }
    DiscretizationSpec spec;
    if (name.text == "galerkin_gauss" || name.text == "galerkin_lobatto") {
      if (!has_value) fail(line, name, name.text + " needs its parameter s, e.g. " + name.text + "(s=4) (consistency order 2 s)");
      spec = galerkin_spec(name.text == "galerkin_gauss" ? DiscretizationKind::galerkin_gauss
                                                         : DiscretizationKind::galerkin_lobatto,
                           model_.order, value.to_int());
    } else if (name.text == "hermite_gauss") {
      spec.kind = DiscretizationKind::hermite_gauss;
      spec.stages = has_value ? value.to_int() : model_.order;
      if (spec.stages < model_.order) {
        fail(line.number, value_col,
             "hermite_gauss(s=" + std::to_string(spec.stages) + ") is not regular for an order-" +
                 std::to_string(model_.order) + " model: the interpolant's derivative of order " +
                 std::to_string(model_.order) + " is a polynomial of degree " + std::to_string(model_.order - 1) +
                 " that can vanish at all " + std::to_string(spec.stages) + " Gauss points (s must be at least " +
                 std::to_string(model_.order) + ")");
      }
      spec = hermite_gauss_spec(model_.order, spec.stages);
    } else if (model_.order == 1 && (name.text == "trapezoid" || name.text == "midpoint")) {
      if (has_value) {
        fail(line.number, value_col, "'trapezoid' takes no parameters for order-1 models (alpha is for order 2)");
      }
      spec.kind = name.text == "trapezoid" ? DiscretizationKind::trapezoid : DiscretizationKind::midpoint;
      spec.name = spec.ident = name.text;
      spec.consistency_order = 2;
    } else if (model_.order == 2 && name.text == "trapezoid") {
      spec.kind = DiscretizationKind::trapezoid_alpha;
      spec.alpha = value;
      spec.name = "trapezoid(alpha=" + rational_text(value) + ")";
      spec.ident = "trapezoid_alpha_" + rational_ident(value);
      spec.consistency_order = 2;
    } else if (model_.order == 2 && name.text == "gauss2") {
      spec.kind = DiscretizationKind::gauss2;
      spec.name = spec.ident = "gauss2";
      spec.consistency_order = 4;
    } else if (name.text == "trapezoid" || name.text == "midpoint" || name.text == "gauss2") {
      fail(line, name, "'" + name.text + "' is not available for order-" + std::to_string(model_.order) +
                           " models (available: " + available + ")");
    } else {
      fail(line, name, "unknown discretization '" + name.text + "' (available for order-" +
                           std::to_string(model_.order) + " models: " + available + ")");
    }
    auto it = seen.find(spec.name);
    if (it != seen.end()) {
      fail(line, name, "duplicate discretization '" + spec.name + "'");
    }
    seen[spec.name] = name.col;
    model_.discretizations.push_back(spec);
  }
}

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

GiNaC::ex Reader::parse_full_expression(const Line& line, std::size_t pos, const ExprContext& ctx) const {
  Cursor c{&line, pos};
  GiNaC::ex value = parse_expression(c, ctx);
  const Token& rest = c.peek();
  if (rest.kind != Tok::end) {
    if (rest.kind == Tok::op && rest.text == ")") fail(line, rest, "unmatched ')'");
    fail(line, rest, "expected an operator or the end of the line, found " + rest.shown());
  }
  return value;
}

LagModel Reader::read() {
  std::vector<Line> lines;
  for (int n = 1; n <= static_cast<int>(raw_lines_.size()); ++n) {
    Line l = tokenize(n);
    if (l.tokens.size() == 1) continue;  // blank or comment
    lines.push_back(l);
  }
  for (const Line& l : lines) read_declaration(l);

  auto missing = [&](const std::string& what) {
    int n = raw_lines_.empty() ? 1 : static_cast<int>(raw_lines_.size());
    int col = raw_lines_.empty() ? 1 : static_cast<int>(raw_lines_[n - 1].size()) + 1;
    fail(n, col, "missing " + what);
  };
  if (model_line_ == 0) missing("'model NAME' line");
  if (coords_line_ == 0) missing("'coords' line (the generalized coordinates)");
  if (!lagrangian_line_) missing("'L = ...' line (the Lagrangian)");

  model_.coord_symbols.resize(static_cast<std::size_t>(model_.order) + 1);
  for (int k = 0; k <= model_.order; ++k) {
    for (const std::string& name : model_.coords) {
      model_.coord_symbols[static_cast<std::size_t>(k)].push_back(
          GiNaC::symbol(name + std::string(static_cast<std::size_t>(k), '\'')));
    }
  }

  std::string order_reason = "the model has order " + std::to_string(model_.order);
  for (const Line& l : let_lines_) {
    ExprContext ctx;
    ctx.max_derivative = model_.order;
    ctx.derivative_limit_reason = order_reason.c_str();
    ctx.let_limit_line = l.number;
    LetDecl& let = lets_[l.tokens[1].text];
    let.value = parse_full_expression(l, 3, ctx);
    let.defined = true;
  }
  const int after_all = static_cast<int>(raw_lines_.size()) + 1;
  {
    ExprContext ctx;
    ctx.max_derivative = model_.order;
    ctx.derivative_limit_reason = order_reason.c_str();
    ctx.let_limit_line = after_all;
    model_.lagrangian = parse_full_expression(*lagrangian_line_, 2, ctx);
    model_.lagrangian_line = lagrangian_line_->number;
    model_.lagrangian_column = lagrangian_line_->tokens[2].col;
  }
  if (clock_line_) {
    ExprContext ctx;
    ctx.max_derivative = model_.order == 1 ? 1 : model_.order - 1;
    std::string reason = "the clock of an order-" + std::to_string(model_.order) + " model may use derivatives up to order " +
                         std::to_string(ctx.max_derivative) + " only";
    ctx.derivative_limit_reason = reason.c_str();
    ctx.let_limit_line = after_all;
    model_.clock = parse_full_expression(*clock_line_, 2, ctx);
    model_.has_clock = true;
    model_.clock_line = clock_line_->number;
    model_.clock_column = clock_line_->tokens[2].col;
  }
  if (cost_line_ && model_.cost_kind == "clock" && !clock_line_) {
    fail(*cost_line_, cost_line_->tokens[3], "a cost that is the summed clock needs a 'clock = ...' declaration");
  }
  if (discretization_line_) {
    read_discretizations(*discretization_line_);
  } else {
    DiscretizationSpec spec;
    if (model_.order >= 3) {
      spec = hermite_gauss_spec(model_.order, model_.order);
    } else if (model_.order == 1) {
      spec.kind = DiscretizationKind::trapezoid;
      spec.name = spec.ident = "trapezoid";
    } else {
      spec.kind = DiscretizationKind::trapezoid_alpha;
      spec.name = "trapezoid(alpha=1)";
      spec.ident = "trapezoid_alpha_1";
    }
    model_.discretizations.push_back(spec);
  }
  model_.filename = filename_;
  model_.source_lines = raw_lines_;
  model_.terms = std::move(terms_);
  return model_;
}

}  // namespace

bool LagModel::time_dependent() const {
  return lagrangian.has(time) || (has_clock && clock.has(time));
}

std::string lag_diagnostic(const std::string& filename, const std::string& source_line, int line, int col,
                           const std::string& message) {
  std::ostringstream out;
  out << filename << ':' << line << ':' << col << ": error: " << message << '\n';
  std::string shown;
  std::string caret;
  for (std::size_t i = 0; i < source_line.size(); ++i) {
    unsigned char c = static_cast<unsigned char>(source_line[i]);
    char s = (c == '\t') ? '\t' : (c < 0x20 || c == 0x7f) ? '?' : static_cast<char>(c);
    shown += s;
    if (static_cast<int>(i) + 1 < col) caret += (c == '\t') ? '\t' : ' ';
  }
  while (static_cast<int>(caret.size()) + 1 < col) caret += ' ';
  out << "  " << shown << '\n' << "  " << caret << '^';
  return out.str();
}

LagModel parse_lag(const std::string& text, const std::string& filename) {
  // Editors on some systems start UTF-8 files with a byte-order mark: skipped (columns count
  // from the byte after it). A UTF-16 or UTF-32 file is refused by name rather than byte by byte.
  const std::string_view bom = "\xef\xbb\xbf";
  const bool has_bom = text.compare(0, bom.size(), bom) == 0;
  if (text.compare(0, 2, "\xff\xfe") == 0 || text.compare(0, 2, "\xfe\xff") == 0 ||
      text.compare(0, 4, std::string("\0\0\xfe\xff", 4)) == 0) {
    const std::string first_line = text.substr(0, text.find('\n'));
    const std::string message = "the file is UTF-16 or UTF-32 (it starts with a byte-order mark); save it as UTF-8";
    throw LagError(lag_diagnostic(filename, first_line, 1, 1, message), 1, 1, message);
  }
  Reader reader(has_bom ? text.substr(bom.size()) : text, filename);
  return reader.read();
}

LagModel parse_lag_file(const std::string& path) {
  // A regular file of at most 1 MiB, checked before reading (a FIFO, a device, a folder or a
  // sparse file of gigabytes is refused by name); the diagnostic is located at 1:1.
  std::string text;
  try {
    text = pardel::read_regular_file(path, pardel::FileLimits::lag, ".lag file");
  } catch (const pardel::FileError& error) {
    throw LagError(path + ":1:1: error: " + error.reason(), 1, 1, error.reason());
  }
  return parse_lag(text, path);
}

}  // namespace pardel_codegen
