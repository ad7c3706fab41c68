/**
 * @file model_loader.hpp
 * Resolves a model named in a scene or on the command line: either a bundled model compiled
 * into this binary, or a path to a .lag file, which is generated (pardel-gen + render), compiled
 * into a shared object in a cache folder and loaded on first use.
 */
#ifndef PARDEL_MODEL_LOADER_HPP
#define PARDEL_MODEL_LOADER_HPP

#include <functional>
#include <stdexcept>
#include <string>

#include "pardel/kernel_abi.h"

namespace pardel {

/** Raised when a model cannot be resolved; what() carries the generator's diagnostics
 *  (FILE:LINE:COL: error: ...) or the reason (unknown name, compiler failure). */
class ModelLoadError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/**
 * A bundled model's name, or a path to a .lag file (anything ending in ".lag" or containing '/').
 * The returned model stays valid for the life of the process. Compiled .lag files are cached
 * under $PARDEL_CACHE_DIR, else $XDG_CACHE_HOME/pardel, else $HOME/.cache/pardel, else (none set)
 * a private folder of the process made by mkdtemp and removed at exit, so that nothing is reused;
 * an entry is keyed by a SHA-256 digest of the file's content, the generator and the compiler;
 * concurrent callers and processes (on one host or several sharing the cache) are safe.
 * The cache folder is created with mode 0700 and refused (ModelLoadError naming the path and the
 * reason) when it is a symbolic link, another user's or writable by group or others. An entry is
 * loaded only when its folder and files are this user's alone, no links, and its model.so,
 * model_name.txt and warnings.txt match the SHA-256 digests recorded in its sha256sums.txt when it
 * was built; model.so is loaded through the descriptor that was verified. A bad entry is removed
 * and compiled again, and model_warnings(model) begins with a line saying why ("warning: the
 * cached model DIR was not loaded and is compiled again: REASON").
 */
const pardel_model* resolve_model(const std::string& name_or_path);

/**
 * The warnings pardel-gen printed when it generated `model` from its .lag file, as it prints them
 * ("FILE:LINE:COL: warning: model 'NAME': ..." with the source line and a caret; FILE is the path
 * resolve_model was given), one diagnostic after another; empty for a bundled model, a model without warnings
 * or a pointer resolve_model did not return. They are kept with the cache entry, so a model loaded
 * from the cache has them too. The loader prints nothing: its callers report them (the command
 * line on stderr, the Python module as a pardel.ModelWarning), once per model and process.
 */
std::string model_warnings(const pardel_model* model);

/** Sets what resolve_model calls, with the path it was given, just before it compiles a .lag file
 *  that has no usable cache entry (a compile takes seconds, minutes for a large model under a
 *  high-order discretization, where a command line says what it is waiting for); an empty
 *  function: nothing. The loader itself prints nothing. */
void set_compile_notice(std::function<void(const std::string& path)> notice);

/** Sets what the loader polls (every 20 ms) while a program of a compile runs: when it returns
 *  true, the program's process group is terminated, the entry's temporary folder removed and
 *  resolve_model throws ModelLoadError("interrupted while compiling FILE"). An empty function (the
 *  default): a compile runs to its end (pardel's Python module lets it finish in the background). */
void set_compile_interrupt(std::function<bool()> stop);

/** True when this build can compile .lag files at run time (pardel-gen and a compiler found). */
bool can_compile_lag_files();

/** What compiles a .lag file: the generator, the Python that runs the render script (with
 *  Jinja2), the render script, the C++ compiler and the folder holding pardel/kernel_abi.h. */
struct LoaderToolchain {
  std::string generator;
  std::string python;
  std::string render_script;
  std::string compiler;
  std::string abi_include;
};

/** The toolchain in use: the build tree's (fixed when pardel was built) unless replaced. All
 *  fields are empty in a build without the generator. */
LoaderToolchain loader_toolchain();

/** Replaces the toolchain for the rest of the process (an installed copy of pardel points the
 *  loader at its installed pardel-gen and render script). Has no effect in a build without the
 *  generator, which cannot compile .lag files. */
void set_loader_toolchain(const LoaderToolchain& toolchain);

}  // namespace pardel

#endif  // PARDEL_MODEL_LOADER_HPP
