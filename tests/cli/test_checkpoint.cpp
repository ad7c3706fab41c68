// Tests of the checkpoint reader (pardel/app/checkpoint.hpp) on text: a checkpoint written by
// checkpoint_json reads back to the same state, and the inputs that the checkpoint fuzzer found
// (tests/fuzz/regressions_checkpoint/) are refused with "FILE: error: " and the key at fault.
#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>

#include "pardel/app/checkpoint.hpp"
#include "pardel/pardel.hpp"

namespace {

using pardel::app::Checkpoint;
using pardel::app::CheckpointError;

const std::string kPath = "out/checkpoint.json";

/** A small checkpoint of jacobi-newton on N = 2, dim 1, with one history record. */
Checkpoint small_checkpoint() {
  Checkpoint c;
  c.scene_path = "/scenes/small.toml";
  c.scene_hash = pardel::app::fnv1a_hex("model = \"harmonic\"\n");
  c.overrides = {"solver.tol=1e-9"};
  c.threads = 2;
  c.model = "harmonic";
  c.dim = 1;
  pardel::SolverState& s = c.state;
  s.method = pardel::Method::jacobi_newton;
  s.N = 2;
  s.iteration = 3;
  s.level_iteration = 3;
  s.next_record = 4;
  s.have_initial_residual = true;
  s.initial_residual = 0.5;
  s.last_good_residual = 0.25;
  s.best_residual = std::numeric_limits<double>::infinity();
  s.seconds = 0.125;
  s.trajectory.N = 2;
  s.trajectory.dim = 1;
  s.trajectory.t = {0, 1, 2};
  s.trajectory.q = {0, 0.4, 1};
  s.history.push_back({3, 2, 0.25, -0.5, 0.125});
  s.valid = true;
  return c;
}

/** The checkpoint's text with its body edited and the checksum the edited body has. */
std::string edited(const std::function<void(nlohmann::json&)>& edit) {
  nlohmann::json file = nlohmann::json::parse(pardel::app::checkpoint_json(small_checkpoint()));
  edit(file["body"]);
  file["checksum"] = pardel::app::fnv1a_hex(file["body"].dump());
  return file.dump();
}

std::string error_of(const std::string& text) {
  try {
    pardel::app::parse_checkpoint(text, kPath);
  } catch (const CheckpointError& error) {
    return error.what();
  }
  return "";
}

TEST(CheckpointReader, WrittenCheckpointReadsBackExactly) {
  const Checkpoint c = pardel::app::parse_checkpoint(pardel::app::checkpoint_json(small_checkpoint()), kPath);
  EXPECT_EQ(c.scene_path, "/scenes/small.toml");
  EXPECT_EQ(c.overrides, std::vector<std::string>{"solver.tol=1e-9"});
  EXPECT_EQ(c.threads, 2);
  EXPECT_EQ(c.state.method, pardel::Method::jacobi_newton);
  EXPECT_EQ(c.state.trajectory.q, (std::vector<double>{0, 0.4, 1}));
  EXPECT_EQ(c.state.best_residual, std::numeric_limits<double>::infinity());
  ASSERT_EQ(c.state.history.size(), 1u);
  EXPECT_EQ(c.state.history[0].N, 2);
  EXPECT_EQ(pardel::app::checkpoint_json(c), pardel::app::checkpoint_json(small_checkpoint()));
}

TEST(CheckpointReader, NumberBeyondDoubleIsACorruptFileNotAnInternalError) {
  // Escaped the reader as nlohmann's out_of_range ("pardel: error: [json.exception.out_of_range.406]").
  std::string text = pardel::app::checkpoint_json(small_checkpoint());
  text.replace(text.find("\"seconds\":"), 10, "\"seconds\":1e400,\"x\":");
  EXPECT_EQ(error_of(text),
            kPath + ": error: not a valid checkpoint (JSON number overflow parsing '1e400'); the file is corrupted");
}

TEST(CheckpointReader, UnsignedIntegerBeyondLongIsOutOfRange) {
  // 2^64 - 1 was read as -1 and accepted as "threads not given".
  const std::string text =
      edited([](nlohmann::json& body) { body["scene"]["threads"] = std::numeric_limits<std::uint64_t>::max(); });
  EXPECT_EQ(error_of(text), kPath + ": error: key scene.threads = 18446744073709551615 is out of range [-1, 4096]");
}

TEST(CheckpointReader, HistoryIntegersAreRangeChecked) {
  // An N beyond int was truncated, a negative iteration accepted.
  EXPECT_EQ(error_of(edited([](nlohmann::json& body) { body["state"]["history"][0][1] = 2147483648000LL; })),
            kPath + ": error: key state.history[0][1] (N) = 2147483648000 is out of range [0, 2147483647]");
  EXPECT_EQ(error_of(edited([](nlohmann::json& body) { body["state"]["history"][0][0] = -1; })),
            kPath + ": error: key state.history[0][0] (iteration) = -1 is out of range [0, 9223372036854775807]");
}

}  // namespace
