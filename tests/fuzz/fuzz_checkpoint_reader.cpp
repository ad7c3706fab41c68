/**
 * @file fuzz_checkpoint_reader.cpp
 * Fuzz entry for the checkpoint reader (pardel::app::parse_checkpoint, what `pardel solve
 * --resume` reads from OUTPUT/checkpoint.json). Contract checked on every input:
 *   - parse_checkpoint either returns a checkpoint or throws CheckpointError; any other
 *     exception, a crash, a hang or a leak is a defect;
 *   - a CheckpointError reads "fuzz/checkpoint.json: error: MESSAGE";
 *   - an accepted checkpoint has consistent sizes (N + 1 node times, (N + 1) dim values, the same
 *     dim in the model and the state, a previous level that fits its own N), and written again by
 *     checkpoint_json it reads back to the same text.
 * Random bytes rarely carry a matching checksum, which would keep the fuzzer at the checksum test:
 * when the reader's only objection is the checksum, the body is read a second time with the
 * checksum it should have, so that the fields behind it are fuzzed too.
 * Built as a libFuzzer target with clang (fuzz_checkpoint_reader) and, with any compiler, as a
 * corpus replay program (fuzz_checkpoint_reader_replay, see corpus_replay_main.cpp).
 */
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "pardel/app/checkpoint.hpp"

namespace {

const char kPath[] = "fuzz/checkpoint.json";

[[noreturn]] void violated(const std::string& what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_checkpoint_reader: contract violated: %s\n%s\n", what.c_str(), detail.c_str());
  std::abort();
}

void check_accepted(const pardel::app::Checkpoint& c) {
  const pardel::SolverState& s = c.state;
  const std::size_t n1 = static_cast<std::size_t>(s.N) + 1;
  if (!s.valid || s.N < 2 || c.dim < 1) violated("accepted a checkpoint with N < 2 or dim < 1", "");
  if (s.trajectory.dim != c.dim || s.trajectory.N != s.N) violated("state dim or N differs from the checkpoint's", "");
  if (s.trajectory.t.size() != n1 || s.trajectory.q.size() != n1 * static_cast<std::size_t>(c.dim))
    violated("accepted a state whose t or q does not fit N and dim", "");
  if (s.previous_level.N != 0) {
    const std::size_t p1 = static_cast<std::size_t>(s.previous_level.N) + 1;
    if (s.previous_level.N < 2 || s.previous_level.N > s.N || s.previous_level.t.size() != p1 ||
        s.previous_level.q.size() != p1 * static_cast<std::size_t>(c.dim))
      violated("accepted a previous level that does not fit its N", "");
  } else if (!s.previous_level.t.empty() || !s.previous_level.q.empty()) {
    violated("accepted values for a previous level of N = 0", "");
  }
  // What was read must survive writing and reading again unchanged.
  const std::string once = pardel::app::checkpoint_json(c);
  std::string twice;
  try {
    twice = pardel::app::checkpoint_json(pardel::app::parse_checkpoint(once, kPath));
  } catch (const std::exception& error) {
    violated("an accepted checkpoint, written again, is refused", error.what());
  }
  if (once != twice) violated("an accepted checkpoint does not read back to the same text", once + "\n---\n" + twice);
}

/** Parses `text`; returns the error message, or "" when the checkpoint was accepted. */
std::string parse(const std::string& text) {
  try {
    check_accepted(pardel::app::parse_checkpoint(text, kPath));
    return "";
  } catch (const pardel::app::CheckpointError& error) {
    const std::string what = error.what();
    if (what.rfind(std::string(kPath) + ": error: ", 0) != 0) violated("diagnostic does not start with FILE: error:", what);
    if (what.size() == std::string(kPath).size() + 9) violated("diagnostic without a message", what);
    return what;
  } catch (const std::exception& error) {
    violated("parse_checkpoint threw something other than CheckpointError", error.what());
  }
}

/** True when `error` is the reader's checksum objection (not a message that merely quotes those words). */
bool checksum_refused(const std::string& error) {
  return error.rfind(std::string(kPath) + ": error: checksum mismatch (", 0) == 0;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string error = parse(text);
  if (!checksum_refused(error)) return 0;
  // The reader parsed the file and dumped its body (nesting within its limit): set the checksum
  // that the body has and read it again.
  nlohmann::json file = nlohmann::json::parse(text);
  file["checksum"] = pardel::app::fnv1a_hex(file["body"].dump());
  const std::string fixed = parse(file.dump());
  if (checksum_refused(fixed)) violated("the recomputed checksum is refused", fixed);
  return 0;
}
