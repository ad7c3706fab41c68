/**
 * @file lag_parser.hpp
 * The reader of the .lag language (version 1; see codegen/README.md): turns the text of a model
 * into a LagModel, or reports the first error as `FILE:LINE:COL: error: MESSAGE`, followed by the
 * source line and a caret under the column.
 */
#ifndef PARDEL_CODEGEN_LAG_PARSER_HPP
#define PARDEL_CODEGEN_LAG_PARSER_HPP

#include <stdexcept>
#include <string>

#include "pardel_codegen/lag_model.hpp"

namespace pardel_codegen {

/** A user error in a .lag file; what() is the full diagnostic (with source line and caret). */
class LagError : public std::runtime_error {
 public:
  LagError(const std::string& diagnostic, int line, int column, std::string message)
      : std::runtime_error(diagnostic), line_(line), column_(column), message_(std::move(message)) {}
  int line() const { return line_; }          ///< 1-based
  int column() const { return column_; }      ///< 1-based, in bytes of the original line
  const std::string& message() const { return message_; }  ///< the text after "error: "
 private:
  int line_;
  int column_;
  std::string message_;
};

/** Longest identifier accepted (coordinates, params, lets). */
constexpr std::size_t kMaxIdentifierLength = 64;
/** Longest model name accepted (it prefixes every emitted C symbol). */
constexpr std::size_t kMaxModelNameLength = 48;

/** The diagnostic `FILE:LINE:COL: error: MESSAGE`, the source line and a caret under the column. */
std::string lag_diagnostic(const std::string& filename, const std::string& source_line, int line, int col,
                           const std::string& message);

/**
 * Parses the text of a .lag file. `filename` is used only in diagnostics.
 * @throws LagError on the first error in the file.
 */
LagModel parse_lag(const std::string& text, const std::string& filename);

/** Reads and parses a .lag file. @throws LagError (also when the file cannot be read). */
LagModel parse_lag_file(const std::string& path);

}  // namespace pardel_codegen

#endif  // PARDEL_CODEGEN_LAG_PARSER_HPP
