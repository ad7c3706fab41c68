// `pardel sweep`: the subcommand's options, the spreading of variants over MPI ranks with the
// gathering of their results on rank 0, and the report (see sweep_command.hpp).
#include "sweep_command.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <stdexcept>
#include <thread>

#include "outputs.hpp"
#include "pardel/mpi_session.hpp"
#include "pardel_cli/config.hpp"
#include "trajectory_io.hpp"

#ifdef PARDEL_HAVE_MPI
#include <mpi.h>
#endif

namespace pardel::cli {

namespace fs = std::filesystem;

namespace {

const char* const kSweepExitCodesHelp =
    "Exit codes: 0 at least one variant converged (sweep.json counts the failures), 1 internal error\n"
    "(e.g. an output file cannot be written), 2 invalid input (bad sweep file, scene or option),\n"
    "6 interrupted (Ctrl-C or SIGTERM; the outputs hold the variants done), 8 no variant converged.";

std::atomic<bool> g_sweep_interrupted{false};
extern "C" void on_sweep_signal(int) { g_sweep_interrupted.store(true); }

// ---------------------------------------------------------------------------------------------
// Results as bytes, to gather them over MPI.

class Packer {
 public:
  template <typename T>
  void put(const T& value) {
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void put_string(const std::string& text) {
    put(static_cast<std::uint64_t>(text.size()));
    bytes_.append(text);
  }
  void put_doubles(const std::vector<double>& values) {
    put(static_cast<std::uint64_t>(values.size()));
    bytes_.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(double));
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

class Unpacker {
 public:
  Unpacker(const char* data, std::size_t size) : data_(data), size_(size) {}
  template <typename T>
  T get() {
    T value;
    take(&value, sizeof(T));
    return value;
  }
  std::string get_string() {
    const auto n = static_cast<std::size_t>(get<std::uint64_t>());
    check(n);
    std::string text(data_ + offset_, n);
    offset_ += n;
    return text;
  }
  std::vector<double> get_doubles() {
    const auto n = static_cast<std::size_t>(get<std::uint64_t>());
    check(n * sizeof(double));
    std::vector<double> values(n);
    take(values.data(), n * sizeof(double));
    return values;
  }
  bool done() const { return offset_ == size_; }

 private:
  void check(std::size_t n) const {
    if (n > size_ - offset_) throw std::logic_error("sweep: truncated result message");
  }
  void take(void* out, std::size_t n) {
    check(n);
    std::memcpy(out, data_ + offset_, n);
    offset_ += n;
  }
  const char* data_;
  std::size_t size_;
  std::size_t offset_ = 0;
};

void pack(Packer& p, const VariantResult& r) {
  p.put<std::int64_t>(r.id);
  p.put<std::int64_t>(r.configuration);
  p.put_string(r.status);
  p.put_string(r.message);
  p.put<std::int64_t>(r.iterations);
  p.put(r.residual);
  p.put(r.action);
  p.put(r.cost);
  p.put(r.seconds);
  p.put<std::int64_t>(r.hessian_positive_definite);
  p.put<std::int64_t>(r.inertia_negative);
  p.put<std::int64_t>(r.inertia_zero);
  p.put<std::int64_t>(r.certificate_valid);
  p.put<std::int64_t>(r.trajectory.N);
  p.put<std::int64_t>(r.trajectory.dim);
  p.put_doubles(r.trajectory.t);
  p.put_doubles(r.trajectory.q);
}

VariantResult unpack(Unpacker& u) {
  VariantResult r;
  r.id = static_cast<int>(u.get<std::int64_t>());
  r.configuration = static_cast<int>(u.get<std::int64_t>());
  r.status = u.get_string();
  r.message = u.get_string();
  r.iterations = static_cast<long>(u.get<std::int64_t>());
  r.residual = u.get<double>();
  r.action = u.get<double>();
  r.cost = u.get<double>();
  r.seconds = u.get<double>();
  r.hessian_positive_definite = u.get<std::int64_t>() != 0;
  r.inertia_negative = static_cast<long>(u.get<std::int64_t>());
  r.inertia_zero = static_cast<long>(u.get<std::int64_t>());
  r.certificate_valid = u.get<std::int64_t>() != 0;
  r.trajectory.N = static_cast<int>(u.get<std::int64_t>());
  r.trajectory.dim = static_cast<int>(u.get<std::int64_t>());
  r.trajectory.t = u.get_doubles();
  r.trajectory.q = u.get_doubles();
  return r;
}

/** Threads per variant: --threads when given; under several ranks on a node, the scene's "all
 *  cores" (0) becomes the node's cores shared among its ranks. 0 keeps the scene's value. */
int threads_per_variant(const SweepArgs& args, const Sweep& sweep, int size) {
  if (args.threads >= 0) return args.threads;
  if (size <= 1 || sweep.configurations.front().options.threads != 0) return 0;
  int local = size;
  for (const char* name : {"OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS"}) {
    if (const char* value = std::getenv(name)) {
      const int n = std::atoi(value);
      if (n > 0) {
        local = n;
        break;
      }
    }
  }
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, cores / local);
}

std::string short_number(double v) { return fmt::format("{:.10g}", v); }

void print_report(const Sweep& sweep, const std::vector<VariantResult>& results,
                  const std::vector<Solution>& solutions, const SweepRunInfo& info, const std::string& out_dir) {
  std::map<std::string, int> failures;
  int converged = 0;
  for (const auto& r : results) {
    if (r.converged()) ++converged;
    else ++failures[r.status];
  }
  std::string failed;
  for (const auto& [status, count] : failures) failed += fmt::format("{}{} {}", failed.empty() ? "" : ", ", count, status);
  const PhysicalCost kind = physical_cost(sweep.configurations.front(), Summary{}, Trajectory{});
  std::cout << fmt::format("sweep {}: {} variant{} on {} rank{}, {} converged{}, {} distinct solution{}, {:.3g} s\n",
                           sweep.path, results.size(), results.size() == 1 ? "" : "s", info.ranks,
                           info.ranks == 1 ? "" : "s", converged, failed.empty() ? "" : " (" + failed + ")",
                           solutions.size(), solutions.size() == 1 ? "" : "s", info.wall_seconds);
  if (solutions.empty()) return;
  const bool several = sweep.configurations.size() > 1;
  std::cout << fmt::format("{:>8}{}{:>5}  {:>18}  {:>18}  {:>9}  {:>8}  {}\n", "solution",
                           several ? fmt::format("{:>7}", "config") : "", "rank",
                           kind.name == "action" ? "cost (action)" : kind.name, "action", "residual",
                           "variants", "certificate");
  for (const auto& s : solutions) {
    std::string verdict = "unknown";
    for (const auto& r : results) {
      if (r.id == s.first_variant) verdict = certificate_verdict(r);
    }
    std::cout << fmt::format("{:>8}{}{:>5}  {:>18}  {:>18}  {:>9.2e}  {:>8}  {}\n", s.id,
                             several ? fmt::format("{:>7}", s.configuration) : "", s.rank, short_number(s.cost),
                             short_number(s.action), s.residual, s.variants.size(), verdict);
  }
  const Solution* best = &solutions.front();
  for (const auto& s : solutions) {
    if (s.cost < best->cost) best = &s;
  }
  std::cout << fmt::format("best: solution {}, {} = {} (first reached by variant {}, {})\n", best->id, kind.name,
                           format_double(best->cost), best->first_variant,
                           make_variant(sweep, best->first_variant).guess_label);
  std::cout << "output: " << out_dir << "\n";
}

int broadcast_code(int code) {
#ifdef PARDEL_HAVE_MPI
  if (pardel::mpi::world_size() > 1) MPI_Bcast(&code, 1, MPI_INT, 0, MPI_COMM_WORLD);
#endif
  return code;
}

}  // namespace

std::vector<VariantResult> run_variants_over_ranks(const Sweep& sweep, int threads, int rank, int size,
                                                   const std::function<void(int, int)>& on_done,
                                                   const std::atomic<bool>* stop) {
  const int total = sweep.variant_count();
  int mine = 0;
  for (int id = rank; id < total; id += size) ++mine;
  std::vector<VariantResult> local;
  local.reserve(static_cast<std::size_t>(mine));
  for (int id = rank; id < total; id += size) {
    local.push_back(solve_variant(sweep, make_variant(sweep, id), threads, stop));
    if (on_done) on_done(static_cast<int>(local.size()), mine);
  }
  if (size <= 1) return local;
#ifdef PARDEL_HAVE_MPI
  Packer packer;
  for (const auto& r : local) pack(packer, r);
  if (packer.bytes().size() > static_cast<std::size_t>(INT_MAX)) {
    throw std::runtime_error("sweep: the results of one rank exceed 2 GiB; use more ranks or fewer variants");
  }
  int bytes = static_cast<int>(packer.bytes().size());
  std::vector<int> counts(rank == 0 ? size : 0);
  MPI_Gather(&bytes, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  std::vector<int> displacements(counts.size());
  std::vector<char> gathered;
  if (rank == 0) {
    long long offset = 0;
    for (int r = 0; r < size; ++r) {
      displacements[r] = static_cast<int>(offset);
      offset += counts[r];
      if (offset > INT_MAX) throw std::runtime_error("sweep: the gathered results exceed 2 GiB");
    }
    gathered.resize(static_cast<std::size_t>(offset));
  }
  MPI_Gatherv(packer.bytes().data(), bytes, MPI_BYTE, gathered.data(), counts.data(), displacements.data(), MPI_BYTE,
              0, MPI_COMM_WORLD);
  if (rank != 0) return {};
  std::vector<VariantResult> all(static_cast<std::size_t>(total));
  std::vector<bool> seen(static_cast<std::size_t>(total), false);
  for (int r = 0; r < size; ++r) {
    Unpacker u(gathered.data() + displacements[r], static_cast<std::size_t>(counts[r]));
    while (!u.done()) {
      VariantResult result = unpack(u);
      if (result.id < 0 || result.id >= total || seen[result.id]) throw std::logic_error("sweep: bad variant id");
      seen[result.id] = true;
      all[result.id] = std::move(result);
    }
  }
  for (int id = 0; id < total; ++id) {
    if (!seen[id]) throw std::logic_error(fmt::format("sweep: no result for variant {}", id));
  }
  return all;
#else
  throw std::logic_error("sweep: several ranks in a build without MPI");
#endif
}

SweepCommand::SweepCommand(CLI::App& app) {
  command_ = app.add_subcommand("sweep", "Solve many variants of a scene (guesses, params) and list the distinct "
                                         "local solutions; spreads over MPI ranks under mpirun");
  command_->footer(kSweepExitCodesHelp);
  command_->add_option("sweep", args_.sweep, "Sweep file (TOML, see docs/sweeps.md)")->required();
  command_->add_option("--out", args_.out, "Output folder (default: [output].dir, else out/<sweep-stem>)");
  command_->add_option("--set", args_.sets, "KEY=VALUE: override a key of the base scene for every variant (repeatable)")
      ->allow_extra_args(false);
  command_->add_option("--threads", args_.threads, "Threads per variant (0: all cores); overrides solver.threads")
      ->check(CLI::Range(0, 4096));
  command_->add_flag("--quiet", args_.quiet, "Nothing on stdout");
  command_->add_flag("--no-plot", args_.no_plot, "Do not draw sweep.png");
}

int SweepCommand::run(const ModelResolver& resolve, const std::vector<std::string>& model_names) const {
  const int rank = pardel::mpi::world_rank();
  const int size = pardel::mpi::world_size();
  Sweep sweep;
  try {
    sweep = load_sweep(args_.sweep, args_.sets, resolve, model_names);
  } catch (const SceneError& error) {
    // Every rank reads the same file and fails alike; one message is enough.
    if (rank == 0) std::fprintf(stderr, "%s\n", error.what());
    return 2;
  }
  const int threads = threads_per_variant(args_, sweep, size);
  const auto start = std::chrono::steady_clock::now();
  const bool show_progress = !args_.quiet && rank == 0 && ::isatty(STDERR_FILENO);
  g_sweep_interrupted.store(false);
  auto previous_int = std::signal(SIGINT, on_sweep_signal);
  auto previous_term = std::signal(SIGTERM, on_sweep_signal);
  std::vector<VariantResult> results = run_variants_over_ranks(
      sweep, threads, rank, size,
      [show_progress, size](int done, int mine) {
        if (!show_progress) return;
        std::fprintf(stderr, "\rsweep: %d of %d variants%s", done, mine, size > 1 ? " on rank 0" : "");
        if (done == mine) std::fprintf(stderr, "\n");
      },
      &g_sweep_interrupted);
  std::signal(SIGINT, previous_int);
  std::signal(SIGTERM, previous_term);
  int code = 0;
  if (rank == 0) {
    try {
      SweepRunInfo info;
      info.ranks = size;
      info.threads = threads > 0 ? threads : sweep.configurations.front().options.threads;
      info.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      std::vector<int> solution_of;
      const std::vector<Solution> solutions = group_solutions(results, sweep.grouping, &solution_of);
      std::string out_dir = args_.out;
      if (out_dir.empty()) out_dir = sweep.output_dir;
      if (out_dir.empty()) out_dir = (fs::path("out") / fs::path(args_.sweep).stem()).string();
      write_sweep_outputs(sweep, results, solutions, solution_of, info, out_dir);
      if (!args_.no_plot && sweep.plot && !solutions.empty()) {
        run_plot_script((fs::path(config::plot_script).parent_path() / "plot_sweep.py").string(), out_dir,
                        "sweep.png");
      }
      if (!args_.quiet) print_report(sweep, results, solutions, info, out_dir);
      const bool interrupted = std::any_of(results.begin(), results.end(), [](const VariantResult& r) {
        return r.status == to_string(Termination::interrupted);
      });
      if (interrupted) {
        std::fprintf(stderr, "pardel sweep: interrupted; %s holds the variants done\n", out_dir.c_str());
        code = kSweepExitInterrupted;
      } else if (solutions.empty()) {
        std::fprintf(stderr, "pardel sweep: no variant converged (see %s/variants.csv)\n", out_dir.c_str());
        code = kSweepExitNoSolution;
      }
    } catch (const std::exception& error) {
      std::fprintf(stderr, "pardel sweep: error: %s\n", error.what());
      code = 1;
    }
  }
  return broadcast_code(code);
}

}  // namespace pardel::cli
