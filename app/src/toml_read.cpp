// Checked reads of TOML values shared by the scene and sweep readers (see toml_read.hpp).
#include "toml_read.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "pardel/app/scene.hpp"

namespace pardel::app::detail {

std::string type_name(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a floating-point number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    case toml::node_type::date: return "a date";
    case toml::node_type::time: return "a time";
    case toml::node_type::date_time: return "a date-time";
    default: return "nothing";
  }
}

std::string show_value(const toml::node& node) {
  if (const auto* s = node.as_string()) return fmt::format("\"{}\"", s->get());
  if (node.is_table()) return "{...}";
  std::ostringstream out;
  node.visit([&](const auto& v) { out << v; });
  std::string text = out.str();
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  return text;
}

std::string join(const std::vector<std::string>& names, const char* separator) {
  std::string out;
  for (std::size_t i = 0; i < names.size(); ++i) out += (i ? separator : "") + names[i];
  return out;
}

toml::table parse_document(std::string_view text, const std::string& source_name) {
  // Some editors write a byte-order mark, which the ASCII filter below would refuse.
  if (text.substr(0, 3) == "\xef\xbb\xbf") text.remove_prefix(3);
  check_ascii_outside_strings(text, source_name);
  try {
    return toml::parse(text, source_name);
  } catch (const toml::parse_error& error) {
    throw SceneError(fmt::format("{}:{}:{}: error: {}", source_name, error.source().begin.line,
                                 error.source().begin.column, error.description()));
  }
}

std::string resolve_relative(const std::string& base_file, const std::string& path) {
  namespace fs = std::filesystem;
  try {
    const fs::path p(path);
    if (p.is_absolute()) return path;
    return (fs::path(base_file).parent_path() / p).lexically_normal().string();
  } catch (const std::exception&) {
    return path;
  }
}

std::string TomlReader::where(const toml::source_region& source, const std::string& /*dotted*/) const {
  if (source.begin.line > 0) return fmt::format("{}:{}:{}", file_, source.begin.line, source.begin.column);
  return file_;
}

void TomlReader::fail(const toml::source_region& source, const std::string& dotted, const std::string& message) const {
  throw SceneError(fmt::format("{}: error: {}", where(source, dotted), message));
}

void TomlReader::fail(const toml::node& node, const std::string& dotted, const std::string& message) const {
  fail(node.source(), dotted, message);
}

void TomlReader::check_keys(const toml::table& table, const std::string& prefix, const std::vector<std::string>& allowed,
                            const std::string& note) const {
  for (auto&& [key, node] : table) {
    const std::string name(key.str());
    if (std::find(allowed.begin(), allowed.end(), name) != allowed.end()) continue;
    const std::string dotted = prefix.empty() ? name : prefix + "." + name;
    const std::string suggestion = nearest_name(name, allowed);
    std::string message = fmt::format("unknown key '{}'", dotted);
    if (!suggestion.empty()) {
      message += fmt::format("; did you mean '{}'?", prefix.empty() ? suggestion : prefix + "." + suggestion);
    } else if (!allowed.empty()) {
      message += fmt::format(" (valid keys{}: {})", prefix.empty() ? "" : " in [" + prefix + "]", join(allowed));
    }
    if (!note.empty()) message += " " + note;
    const toml::source_region& source = key.source().begin.line > 0 ? key.source() : node.source();
    fail(source, dotted, message);
  }
}

const toml::table* TomlReader::table(const toml::table& parent, const std::string& key, const std::string& dotted) const {
  const toml::node* node = parent.get(key);
  if (!node) return nullptr;
  if (!node->is_table()) fail(*node, dotted, fmt::format("{} must be a table, got {}", dotted, type_name(*node)));
  return node->as_table();
}

double TomlReader::number(const toml::node& node, const std::string& dotted) const {
  if (node.is_integer()) return static_cast<double>(node.as_integer()->get());
  if (node.is_floating_point()) {
    const double v = node.as_floating_point()->get();
    if (!std::isfinite(v)) fail(node, dotted, fmt::format("{} must be a finite number, got {}", dotted, show_value(node)));
    return v;
  }
  fail(node, dotted, fmt::format("{} must be a number, got {} {}", dotted, type_name(node), show_value(node)));
}

long long TomlReader::integer(const toml::node& node, const std::string& dotted) const {
  if (!node.is_integer()) {
    fail(node, dotted, fmt::format("{} must be an integer, got {} {}", dotted, type_name(node), show_value(node)));
  }
  return node.as_integer()->get();
}

std::string TomlReader::string(const toml::node& node, const std::string& dotted) const {
  if (!node.is_string()) {
    fail(node, dotted, fmt::format("{} must be a string, got {} {}", dotted, type_name(node), show_value(node)));
  }
  return node.as_string()->get();
}

bool TomlReader::boolean(const toml::node& node, const std::string& dotted) const {
  if (!node.is_boolean()) {
    fail(node, dotted, fmt::format("{} must be true or false, got {} {}", dotted, type_name(node), show_value(node)));
  }
  return node.as_boolean()->get();
}

std::vector<double> TomlReader::vector(const toml::node& node, const std::string& dotted, std::size_t size,
                                       const std::string& what) const {
  const toml::array* array = node.as_array();
  if (!array) {
    fail(node, dotted, fmt::format("{} must be an array of {} numbers ({}), got {} {}", dotted, size, what,
                                   type_name(node), show_value(node)));
  }
  if (array->size() != size) {
    fail(node, dotted, fmt::format("{} has {} value{}; expected {} ({})", dotted, array->size(),
                                   array->size() == 1 ? "" : "s", size, what));
  }
  std::vector<double> values;
  for (std::size_t i = 0; i < array->size(); ++i) {
    values.push_back(number(*array->get(i), fmt::format("{}[{}]", dotted, i)));
  }
  return values;
}

}  // namespace pardel::app::detail
