/**
 * @file pardel_gen.cpp
 * The pardel-gen command: reads a .lag model, writes its IR as JSON (-o), and/or prints the
 * operation counts of its kernels before and after CSE (--stats, --stats-json).
 * Before generating it checks that the model is regular (codegen/src/regularity.cpp): a model whose
 * W = d2L/dq^(order)dq^(order) is singular everywhere, or a discretization that is not regular, is
 * refused unless --allow-singular or the .lag allows it.
 * Exit status: 0 on success, 1 on a bad model or an I/O failure, 2 on bad usage.
 */
#include <sys/personality.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <string>

#include "pardel_codegen/lag_parser.hpp"
#include "pardel_codegen/model_ir.hpp"
#include "pardel_codegen/regularity.hpp"

namespace {

const char* kUsage =
    "usage: pardel-gen INPUT.lag [-o OUT.json] [--source-name NAME] [--stats | --stats-json]\n"
    "                  [--allow-singular]\n"
    "\n"
    "Reads a .lag model, discretizes it, differentiates the discrete Lagrangians symbolically\n"
    "(GiNaC), eliminates common subexpressions and writes the intermediate description (IR)\n"
    "that codegen/render.py turns into <model>.hpp and <model>.cpp.\n"
    "\n"
    "  -o OUT.json          write the IR (atomically: nothing is written on error)\n"
    "  --source-name NAME   the .lag path recorded in the IR and the banners (default: INPUT)\n"
    "  --stats              print each kernel's operation count before and after CSE\n"
    "  --stats-json         the same as JSON\n"
    "  --allow-singular     generate a model whose W = d2L/dq^(order)dq^(order) is singular\n"
    "                       everywhere, or a discretization that is not regular, with a\n"
    "                       warning instead of refusing it (also: a .lag line\n"
    "                       '# pardel: allow-singular')\n"
    "  --version, --help\n"
    "\n"
    "Operation counts: each binary + - * /, each unary minus and each function call is one\n"
    "operation; reading an input or a constant is free. 'Before' counts the outputs printed as\n"
    "trees with no sharing; 'after' counts the emitted code.\n";

int usage_error(const std::string& message) {
  std::cerr << "pardel-gen: error: " << message << "\n" << kUsage;
  return 2;
}

bool write_atomically(const std::string& path, const std::string& text) {
  std::string tmp = path + ".tmp." + std::to_string(static_cast<long>(::getpid()));
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return false;
    out << text;
    out.flush();
    if (!out) {
      out.close();
      std::remove(tmp.c_str());
      return false;
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return false;
  }
  return true;
}

/**
 * GiNaC seeds the hashes that order its sums and products with the addresses of type names,
 * so under address-space randomization the order of terms, and with it the emitted code,
 * would change from run to run. Re-executing once without randomization makes the output
 * byte-identical across runs; where that is not permitted the generator still works.
 */
void disable_address_randomization(char** argv) {
  const int current = ::personality(0xffffffff);
  if (current == -1 || (current & ADDR_NO_RANDOMIZE) != 0) return;
  if (::getenv("PARDEL_GEN_NO_REEXEC") != nullptr) return;
  if (::personality(static_cast<unsigned long>(current | ADDR_NO_RANDOMIZE)) == -1) return;
  ::setenv("PARDEL_GEN_NO_REEXEC", "1", 1);
  ::execv("/proc/self/exe", argv);
  // execv failed: continue in this process (output then depends on the address layout).
}

}  // namespace

int main(int argc, char** argv) {
  disable_address_randomization(argv);
  std::string input, output, source_name;
  bool stats = false, stats_json = false, allow_singular = false;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    }
    if (a == "--version") {
      std::cout << "pardel-gen " << pardel_codegen::generator_version() << "\n";
      return 0;
    }
    if (a == "-o" || a == "--source-name") {
      if (i + 1 >= argc) return usage_error("option " + a + " needs a value");
      (a == "-o" ? output : source_name) = argv[++i];
    } else if (a == "--stats") {
      stats = true;
    } else if (a == "--stats-json") {
      stats_json = true;
    } else if (a == "--allow-singular") {
      allow_singular = true;
    } else if (!a.empty() && a[0] == '-') {
      return usage_error("unknown option '" + a + "'");
    } else if (input.empty()) {
      input = a;
    } else {
      return usage_error("more than one input file ('" + input + "', '" + a + "')");
    }
  }
  if (input.empty()) return usage_error("no input .lag file");
  if (output.empty() && !stats && !stats_json) return usage_error("nothing to do: give -o OUT.json, --stats or --stats-json");
  if (source_name.empty()) source_name = input;

  try {
    pardel_codegen::LagModel model = pardel_codegen::parse_lag_file(input);
    for (const std::string& warning : pardel_codegen::check_regularity(model, allow_singular)) {
      std::cerr << warning << "\n";
    }
    pardel_codegen::ModelIR ir = pardel_codegen::build_model_ir_located(model, source_name);
    if (!output.empty()) {
      if (!write_atomically(output, pardel_codegen::ir_to_json(ir))) {
        std::cerr << "pardel-gen: error: cannot write '" << output << "': " << std::strerror(errno) << "\n";
        return 1;
      }
    }
    if (stats) std::cout << pardel_codegen::stats_table(ir);
    if (stats_json) std::cout << pardel_codegen::stats_json(ir);
  } catch (const pardel_codegen::LagError& e) {
    std::cerr << e.what() << "\n";
    return 1;
  } catch (const pardel_codegen::CodegenError& e) {
    std::cerr << input << ": error: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << input << ": error: internal error of pardel-gen: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
