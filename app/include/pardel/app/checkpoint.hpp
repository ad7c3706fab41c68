/**
 * @file checkpoint.hpp
 * Checkpoints of `pardel solve`: when a solve is interrupted (SIGINT, SIGTERM) the solver state
 * (pardel::SolverState: the iterate with its node times, every counter, the method's own state,
 * the history) is written with the scene path, a hash of the scene text, the --set overrides and
 * the thread count into OUTPUT_DIR/checkpoint.json; `pardel solve --resume OUTPUT_DIR` reads it
 * back and continues the solve where it stopped.
 *
 * The file is JSON ("format": "pardel-checkpoint", "version"), every double written exactly
 * (shortest round-trip decimal, or hexadecimal for scalars that may be non-finite), and carries
 * an FNV-1a checksum of its body, so that a truncated, edited or corrupted file is refused with
 * a message naming the file and what is wrong.
 */
#ifndef PARDEL_APP_CHECKPOINT_HPP
#define PARDEL_APP_CHECKPOINT_HPP

#include <stdexcept>
#include <string>
#include <vector>

#include "pardel/app/scene.hpp"
#include "pardel/kernel_abi.h"
#include "pardel/pardel.hpp"

namespace pardel::app {

/** A checkpoint file that cannot be used; what() is "FILE: error: MESSAGE". */
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/** A checkpoint that could not be written (a full disk, a folder without write permission): an
 *  output failure, not bad input (the command line exits 1, as for its other outputs). */
class CheckpointWriteError : public CheckpointError {
 public:
  using CheckpointError::CheckpointError;
};

/** Everything `pardel solve --resume` needs besides the scene file itself. */
struct Checkpoint {
  static constexpr int kVersion = 1;  ///< of the file layout (the state has its own)
  std::string scene_path;             ///< absolute path of the scene file
  std::string scene_hash;             ///< FNV-1a 64 of the scene file's bytes (16 hex digits)
  std::vector<std::string> overrides; ///< the --set KEY=VALUE strings, in order
  int threads = -1;                   ///< --threads as given (-1: not given)
  std::string model;                  ///< the model's name
  int dim = 0;                        ///< the model's dim
  /** model_digest() of the model that wrote it; "" in checkpoints written before it was kept. */
  std::string model_digest;
  SolverState state;
};

/**
 * What identifies a model's kernels, as 16 hex digits (FNV-1a 64), so that `--resume` notices a
 * model that changed since the checkpoint: for a model compiled from a .lag file (`lag_path` not
 * empty), the file's bytes (read as pardel/regular_file.hpp reads users' files: a file that is no
 * longer a regular file of at most 1 MiB throws pardel::FileError); for a model compiled into pardel, its description (name, order,
 * coords, params and defaults, discretizations, clock, cost, kernel ABI) and the values of each
 * discretization's kernel at a fixed point, to 12 significant digits.
 */
std::string model_digest(const pardel_model& model, const std::string& lag_path = "");

/** The name of the checkpoint file inside an output folder. */
inline const char* checkpoint_file_name() { return "checkpoint.json"; }

/** FNV-1a 64 of the bytes, as 16 lowercase hex digits. */
std::string fnv1a_hex(const std::string& bytes);

/** The checkpoint as the text of checkpoint.json. */
std::string checkpoint_json(const Checkpoint& checkpoint);

/** Parses checkpoint text (`path` names it in messages); throws CheckpointError. */
Checkpoint parse_checkpoint(const std::string& text, const std::string& path);

/** Reads DIR/checkpoint.json; throws CheckpointError (also for a missing file). */
Checkpoint read_checkpoint(const std::string& dir);

/** Writes DIR/checkpoint.json atomically (temporary file + rename); throws std::runtime_error. */
void write_checkpoint(const std::string& dir, const Checkpoint& checkpoint);

/** FNV-1a 64 of a scene file's bytes (how a checkpoint recognizes its scene), read as users' files
 *  are read (pardel/regular_file.hpp); a file that cannot be read throws SceneError. */
std::string scene_file_hash(const std::string& path);

/**
 * Checks that `checkpoint`, read from `checkpoint_path`, continues `scene`, loaded again from the
 * checkpoint's scene path and overrides: the scene file unchanged since (its hash), the same model
 * name and dim, and the same model (`digest`: model_digest of the scene's model). Throws
 * CheckpointError "CHECKPOINT_PATH: error: ..." naming what differs. Returns a warning (without a
 * line break) for a checkpoint written without the model's digest, whose model cannot be checked;
 * "" otherwise.
 */
std::string check_resumable(const Checkpoint& checkpoint, const std::string& checkpoint_path, const Scene& scene,
                            const std::string& digest);

/**
 * After a solve that may write checkpoints into `dir`: a solve that ended `interrupted` with its
 * state (Summary::state) writes DIR/checkpoint.json recording `scene_path` (the scene file, whose
 * hash it takes now), `overrides`, `threads`, the model and `digest`, and returns true; a solve
 * that ended any other way removes DIR/checkpoint.json, so that a finished solve cannot be resumed
 * again, and returns false. Throws std::runtime_error when the file cannot be written.
 */
bool update_checkpoint(const std::string& dir, const Summary& summary, const std::string& scene_path,
                       const std::vector<std::string>& overrides, int threads, const pardel_model& model,
                       const std::string& digest);

}  // namespace pardel::app

#endif  // PARDEL_APP_CHECKPOINT_HPP
