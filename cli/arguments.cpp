// What the subcommands of the pardel command line share (see arguments.hpp).
#include "arguments.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace pardel::cli {

double parse_number_option(const std::string& text, const std::string& option) {
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size()) {
    throw UsageError(fmt::format("{}: '{}' is not a number", option, text));
  }
  if (errno == ERANGE) {
    throw UsageError(fmt::format("{}: '{}' is out of the range of a double ({})", option, text,
                                 std::fabs(value) > 1 ? "it overflows" : "it underflows to a subnormal or zero"));
  }
  return value;
}

std::vector<double> parse_vector_option(const std::string& text, const std::string& option, std::size_t size,
                                        const std::string& what) {
  std::vector<double> values;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    values.push_back(parse_number_option(item, option));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (values.size() != size) {
    throw UsageError(fmt::format("{}: {} value{} given; expected {} ({})", option, values.size(),
                                 values.size() == 1 ? "" : "s", size, what));
  }
  return values;
}

}  // namespace pardel::cli
