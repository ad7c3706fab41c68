/**
 * @file fuzz_lag_parser.cpp
 * Fuzz entry for the .lag reader (pardel_codegen::parse_lag). Contract checked on every input:
 *   - the reader either returns a model or throws LagError; any other exception, a crash, a hang
 *     or a leak is a defect;
 *   - a LagError names a LINE:COL inside the input (line 1..number of lines, column 1..length+1)
 *     and its text starts with "fuzz.lag:LINE:COL: error: ";
 *   - when a small model is accepted, the symbolic pipeline (discretize, differentiate, CSE,
 *     JSON IR) runs on it too and either succeeds or throws CodegenError. The pipeline costs about
 *     100 times the reading; with PARDEL_FUZZ_PARSE_ONLY set in the environment it is skipped.
 * Built as a libFuzzer target with clang (fuzz_lag_parser) and, with any compiler, as a corpus
 * replay program (fuzz_lag_parser_replay, see corpus_replay_main.cpp).
 */
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "pardel_codegen/cse.hpp"
#include "pardel_codegen/lag_parser.hpp"
#include "pardel_codegen/model_ir.hpp"

namespace {

const char kSourceName[] = "fuzz.lag";

/** The input's lines as the reader counts them: split at '\n', a final '\n' ends the last line,
 *  a trailing '\r' is not part of a line. */
std::vector<std::size_t> line_lengths(const std::string& text) {
  std::vector<std::size_t> lengths;
  std::size_t start = 0;
  for (;;) {
    const std::size_t nl = text.find('\n', start);
    std::size_t end = nl == std::string::npos ? text.size() : nl;
    std::size_t length = end - start;
    if (length > 0 && text[end - 1] == '\r') --length;
    lengths.push_back(length);
    if (nl == std::string::npos) break;
    start = nl + 1;
  }
  if (lengths.size() > 1 && lengths.back() == 0 && !text.empty() && text.back() == '\n') lengths.pop_back();
  return lengths;
}

[[noreturn]] void violated(const std::string& what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_lag_parser: contract violated: %s\n%s\n", what.c_str(), detail.c_str());
  std::abort();
}

/** Number of nodes of an expression tree (stops counting at `limit`). */
std::size_t tree_size(const GiNaC::ex& e, std::size_t limit) {
  std::size_t n = 0;
  for (GiNaC::const_preorder_iterator it = e.preorder_begin(); it != e.preorder_end() && n <= limit; ++it) ++n;
  return n;
}

/** True when the symbolic pipeline on this model is cheap enough to run per fuzz input. */
bool cheap_enough(const pardel_codegen::LagModel& model) {
  constexpr std::size_t kMaxNodes = 60;
  if (model.ncoords() > 3 || model.order > 2 || model.discretizations.empty()) return false;
  if (tree_size(model.lagrangian, kMaxNodes) > kMaxNodes) return false;
  if (model.has_clock && tree_size(model.clock, kMaxNodes) > kMaxNodes) return false;
  return true;
}

void check_error(const std::string& text, const pardel_codegen::LagError& error) {
  const std::vector<std::size_t> lengths = line_lengths(text);
  const std::string where = std::to_string(error.line()) + ":" + std::to_string(error.column());
  if (error.line() < 1 || static_cast<std::size_t>(error.line()) > lengths.size()) {
    violated("error line " + where + " is outside the input (" + std::to_string(lengths.size()) + " lines)",
             error.what());
  }
  const std::size_t length = lengths[static_cast<std::size_t>(error.line()) - 1];
  if (error.column() < 1 || static_cast<std::size_t>(error.column()) > length + 1) {
    violated("error column " + where + " is outside its line (length " + std::to_string(length) + ")", error.what());
  }
  const std::string head = std::string(kSourceName) + ":" + where + ": error: ";
  if (std::string(error.what()).rfind(head, 0) != 0) violated("diagnostic does not start with " + head, error.what());
  if (error.message().empty()) violated("empty error message", error.what());
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  pardel_codegen::LagModel model;
  try {
    model = pardel_codegen::parse_lag(text, kSourceName);
  } catch (const pardel_codegen::LagError& error) {
    check_error(text, error);
    return 0;
  } catch (const std::exception& error) {
    violated("parse_lag threw something other than LagError", error.what());
  }
  if (std::getenv("PARDEL_FUZZ_PARSE_ONLY") != nullptr || !cheap_enough(model)) return 0;
  try {
    const pardel_codegen::ModelIR ir = pardel_codegen::build_model_ir(model, kSourceName);
    const std::string json = pardel_codegen::ir_to_json(ir);
    if (json.empty()) violated("empty IR", text);
  } catch (const pardel_codegen::CodegenError&) {
    // A model the generator refuses (non-finite or complex constant): a reported user error.
  } catch (const std::exception& error) {
    violated("build_model_ir threw something other than CodegenError", error.what());
  }
  return 0;
}
