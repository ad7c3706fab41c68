/**
 * @file fuzz_trajectory_reader.cpp
 * Fuzz entry for the trajectory and guess CSV reader (pardel::app::read_trajectory_csv, what
 * `pardel check --trajectory` and a scene's CSV guess read). The input becomes the file's bytes and
 * is read for two bundled models of other sizes (fuel_nav: order 1, two coordinates; min_jerk:
 * order 3). Contract checked on every input:
 *   - read_trajectory_csv either returns a trajectory or throws std::runtime_error; any other
 *     exception, a crash, a hang or a leak is a defect;
 *   - an error reads "PATH:LINE:COL: error: MESSAGE" or "PATH: error: MESSAGE";
 *   - an accepted trajectory has N >= 2, N + 1 finite node times and (N + 1) dim finite values,
 *     and written again by trajectory_csv it reads back to the same values.
 * Built as a libFuzzer target with clang (fuzz_trajectory_reader) and, with any compiler, as a
 * corpus replay program (fuzz_trajectory_reader_replay, see corpus_replay_main.cpp).
 */
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "pardel/app/trajectory_io.hpp"
#include "pardel/pardel.hpp"

namespace {

[[noreturn]] void violated(const std::string& what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_trajectory_reader: contract violated: %s\n%s\n", what.c_str(), detail.c_str());
  std::abort();
}

/** The file the input is written to: one per process, in the temporary folder. */
const std::string& input_path() {
  static const std::string path =
      (std::filesystem::temp_directory_path() / ("fuzz_trajectory_" + std::to_string(::getpid()) + ".csv")).string();
  return path;
}

void write_input(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) violated("cannot write the input file", path);
}

void check_accepted(const pardel::Trajectory& tr, const pardel_model& model, const std::string& path) {
  const std::size_t n1 = static_cast<std::size_t>(tr.N) + 1;
  if (tr.N < 2 || tr.dim != model.dim) violated("accepted a trajectory with N < 2 or another dim", model.name);
  if (tr.t.size() != n1 || tr.q.size() != n1 * static_cast<std::size_t>(model.dim))
    violated("accepted a trajectory whose t or q does not fit N and dim", model.name);
  for (double v : tr.t)
    if (!std::isfinite(v)) violated("accepted a node time that is not finite", model.name);
  for (double v : tr.q)
    if (!std::isfinite(v)) violated("accepted a value that is not finite", model.name);
  // What was read must survive writing and reading again unchanged.
  const std::string again = pardel::app::trajectory_csv(model, tr);
  write_input(path, reinterpret_cast<const std::uint8_t*>(again.data()), again.size());
  pardel::Trajectory back;
  try {
    back = pardel::app::read_trajectory_csv(path, model);
  } catch (const std::exception& error) {
    violated("an accepted trajectory, written again, is refused", error.what());
  }
  if (back.N != tr.N || back.t != tr.t || back.q != tr.q)
    violated("an accepted trajectory does not read back to the same values", again);
}

void read_for(const pardel_model& model, const std::uint8_t* data, std::size_t size) {
  const std::string& path = input_path();
  write_input(path, data, size);
  try {
    check_accepted(pardel::app::read_trajectory_csv(path, model), model, path);
  } catch (const std::runtime_error& error) {
    const std::string what = error.what();
    if (what.rfind(path + ":", 0) != 0) violated("diagnostic does not start with the file's path", what);
    if (what.find("error: ", path.size()) == std::string::npos) violated("diagnostic without 'error: '", what);
  } catch (const std::exception& error) {
    violated("read_trajectory_csv threw something other than std::runtime_error", error.what());
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  for (const char* name : {"fuel_nav", "min_jerk"}) {
    const pardel_model* model = pardel::find_model(name);
    if (!model) violated("bundled model missing", name);
    read_for(*model, data, size);
  }
  std::remove(input_path().c_str());
  return 0;
}
