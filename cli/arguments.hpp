/**
 * @file arguments.hpp
 * What the subcommands of the pardel command line share: the usage error (exit code 2, the
 * message names the option) and numbers and vectors read from option values.
 */
#ifndef PARDEL_CLI_ARGUMENTS_HPP
#define PARDEL_CLI_ARGUMENTS_HPP

#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

namespace pardel::cli {

/** A bad command-line value: the message names the option; exit code 2. */
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/** The number in an option's value; UsageError naming `option` when it is not one. */
double parse_number_option(const std::string& text, const std::string& option);

/** `size` comma-separated numbers; UsageError naming `option` and `what` they should be otherwise. */
std::vector<double> parse_vector_option(const std::string& text, const std::string& option, std::size_t size,
                                        const std::string& what);

}  // namespace pardel::cli

#endif  // PARDEL_CLI_ARGUMENTS_HPP
