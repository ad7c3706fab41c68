/**
 * @file lag_reader.hpp
 * Internal to the .lag reader: the tokens and lines of the lexer and the Reader class whose parts
 * live in lag_lexer.cpp (lines and tokens), lag_expression.cpp (the recursive-descent expression
 * parser), lag_declarations.cpp (the declaration lines), lag_discretizations.cpp (the
 * 'discretizations' line) and lag_parser.cpp (the order of the passes and the public entry points).
 * Primes such as x'' are part of the identifier token, so every diagnostic column refers to the
 * original line.
 */
#ifndef PARDEL_CODEGEN_SRC_LAG_READER_HPP
#define PARDEL_CODEGEN_SRC_LAG_READER_HPP

#include <cstddef>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "pardel_codegen/lag_parser.hpp"

namespace pardel_codegen::lag {

/** The functions of one argument (sin, cos, ...); atan2 and pow take two. */
const std::set<std::string>& unary_functions();
bool is_function_name(const std::string& s);
/** t, pi and the function names. */
bool is_reserved_name(const std::string& s);

/** The largest dimension of a point (order x coordinates) the generator takes (lag_parser.cpp). */
constexpr std::size_t kMaxDimension = 128;

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

/**
 * Reads one .lag text. Declarations are read first, so params and coordinates may appear in any
 * order; lets must be defined before they are used.
 */
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

  // The lexer (lag_lexer.cpp).
  void split_lines(const std::string& text);
  Line tokenize(int number) const;

  // The declaration lines (lag_declarations.cpp, lag_discretizations.cpp).
  void read_declaration(const Line& line);
  void read_model(const Line& line);
  void read_order(const Line& line);
  void read_coords(const Line& line);
  void read_param(const Line& line);
  void read_let(const Line& line);
  void read_equation(const Line& line);
  void read_cost(const Line& line);
  void expect_end(const Line& line, std::size_t pos, const char* after) const;
  void declare_name(const Line& line, const Token& tok, const char* what);
  void read_discretizations(const Line& line);
  GiNaC::numeric read_discretization_parameter(const Line& line, const Token& name, std::size_t& i,
                                               int& value_col) const;
  DiscretizationSpec discretization_spec(const Line& line, const Token& name, bool has_value,
                                         const GiNaC::numeric& value, int value_col) const;

  // Expression parsing over one line's tokens (lag_expression.cpp).
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

}  // namespace pardel_codegen::lag

#endif  // PARDEL_CODEGEN_SRC_LAG_READER_HPP
