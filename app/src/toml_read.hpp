// Reading checked values out of a parsed TOML document: the part the scene reader (scene.cpp) and
// the sweep reader (sweep.cpp) share. Every error is a SceneError "WHERE: error: MESSAGE" that
// names the key, what it must be and what it is ("grid.N must be an integer, got a string \"200\"").
// Internal to pardel::app (not installed).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#define TOML_EXCEPTIONS 1
#include <toml++/toml.h>

namespace pardel::app::detail {

/** The kind of a TOML value with its article: "an integer", "a table", "a date-time"... */
std::string type_name(const toml::node& node);

/** A TOML value as shown in a message: strings quoted, tables as {...}, cut at 60 characters. */
std::string show_value(const toml::node& node);

/** The names joined by `separator`. */
std::string join(const std::vector<std::string>& names, const char* separator = ", ");

/** Parses a scene or sweep document: a UTF-8 byte-order mark skipped (columns then count from the
 *  byte after it), non-ASCII bytes outside strings and comments refused (check_ascii_outside_strings),
 *  a syntax error a SceneError "SOURCE:LINE:COL: error: ...". */
toml::table parse_document(std::string_view text, const std::string& source_name);

/** `path` relative to the folder of `base_file` (an absolute path unchanged). */
std::string resolve_relative(const std::string& base_file, const std::string& path);

/**
 * Checked reads of the values of one document. `dotted` is the key's full path (grid.N,
 * boundary.q0[1]); where() says where a value came from, FILE:LINE:COL by default, and a reader
 * whose keys may come from elsewhere (--set) overrides it.
 */
class TomlReader {
 public:
  explicit TomlReader(std::string file) : file_(std::move(file)) {}
  virtual ~TomlReader() = default;

  const std::string& file() const { return file_; }

  /** "FILE:LINE:COL" for a value read from the file, else the file alone. */
  virtual std::string where(const toml::source_region& source, const std::string& dotted) const;

  [[noreturn]] void fail(const toml::source_region& source, const std::string& dotted,
                         const std::string& message) const;
  [[noreturn]] void fail(const toml::node& node, const std::string& dotted, const std::string& message) const;

  /** Every key of `table` must be in `allowed`; the first that is not is an error, with the
   *  nearest allowed name ("did you mean") or the list of them, then `note` where one is given. */
  void check_keys(const toml::table& table, const std::string& prefix, const std::vector<std::string>& allowed,
                  const std::string& note = "") const;

  /** parent[key] as a table; nullptr when the key is absent. */
  const toml::table* table(const toml::table& parent, const std::string& key, const std::string& dotted) const;

  /** A finite number (an integer is taken as one). */
  double number(const toml::node& node, const std::string& dotted) const;
  long long integer(const toml::node& node, const std::string& dotted) const;
  std::string string(const toml::node& node, const std::string& dotted) const;
  bool boolean(const toml::node& node, const std::string& dotted) const;

  /** An array of exactly `size` numbers; `what` explains the expected size. */
  std::vector<double> vector(const toml::node& node, const std::string& dotted, std::size_t size,
                             const std::string& what) const;

 private:
  std::string file_;
};

}  // namespace pardel::app::detail
