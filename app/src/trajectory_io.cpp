// Trajectory CSV files and atomic writes (see trajectory_io.hpp).
#include "pardel/app/trajectory_io.hpp"

#include <fmt/format.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string_view>

#include "pardel/regular_file.hpp"

namespace pardel::app {

std::vector<std::string> state_column_names(const pardel_model& model) {
  std::vector<std::string> names;
  for (int d = 0; d < model.order; ++d) {
    for (int i = 0; i < model.ncoords; ++i) names.push_back(model.coords[i] + std::string(d, '\''));
  }
  return names;
}

namespace {

/** Appends `value` as format_double writes it, without a temporary string. */
void append_double(std::string& out, double value) {
  if (std::isnan(value)) {
    out += "nan";
    return;
  }
  if (std::isinf(value)) {
    out += value > 0 ? "inf" : "-inf";
    return;
  }
  // printf's %.17g, which std::to_chars with a precision is specified to match.
  char digits[32];
  const auto written = std::to_chars(digits, digits + sizeof digits, value, std::chars_format::general, 17);
  out.append(digits, written.ptr);
}

}  // namespace

std::string format_double(double value) {
  std::string out;
  append_double(out, value);
  return out;
}

double node_velocity(const Trajectory& trajectory, int k, int i) {
  const int N = trajectory.N;
  if (N < 1) return std::nan("");
  if (N == 1) {
    const double dt = trajectory.t[1] - trajectory.t[0];
    return dt != 0 ? (trajectory.node(1)[i] - trajectory.node(0)[i]) / dt : std::nan("");
  }
  // The three nodes nearest k: k-1, k, k+1 inside; 0, 1, 2 and N-2, N-1, N at the ends.
  const int a = k == 0 ? 0 : (k == N ? N - 2 : k - 1);
  const double t = trajectory.t[k];
  const double ta = trajectory.t[a], tb = trajectory.t[a + 1], tc = trajectory.t[a + 2];
  if (ta == tb || tb == tc || ta == tc) return std::nan("");
  // The derivative at t of the quadratic through (ta, qa), (tb, qb), (tc, qc) (Lagrange form).
  const double qa = trajectory.node(a)[i], qb = trajectory.node(a + 1)[i], qc = trajectory.node(a + 2)[i];
  return qa * ((t - tb) + (t - tc)) / ((ta - tb) * (ta - tc)) + qb * ((t - ta) + (t - tc)) / ((tb - ta) * (tb - tc)) +
         qc * ((t - ta) + (t - tb)) / ((tc - ta) * (tc - tb));
}

std::string trajectory_csv(const pardel_model& model, const Trajectory& trajectory) {
  const int dim = trajectory.dim;
  const int nc = model.ncoords;
  const bool add_velocity = model.order == 1;
  std::string out = "k,t";
  for (const auto& name : state_column_names(model)) out += "," + name;
  if (add_velocity) {
    for (int i = 0; i < nc; ++i) out += "," + std::string(model.coords[i]) + "'";
  }
  out += '\n';
  const int columns = 2 + dim + (add_velocity ? nc : 0);
  out.reserve(out.size() + static_cast<std::size_t>(trajectory.N + 1) * static_cast<std::size_t>(columns) * 24);
  char index[16];
  for (int k = 0; k <= trajectory.N; ++k) {
    out.append(index, std::to_chars(index, index + sizeof index, k).ptr);
    out += ',';
    append_double(out, trajectory.t[k]);
    const double* q = trajectory.node(k);
    for (int j = 0; j < dim; ++j) {
      out += ',';
      append_double(out, q[j]);
    }
    if (add_velocity) {
      for (int i = 0; i < nc; ++i) {
        out += ',';
        append_double(out, node_velocity(trajectory, k, i));
      }
    }
    out += '\n';
  }
  return out;
}

namespace {

/** The cells of one CSV line as views into it, each without its leading spaces and trailing
 *  spaces and carriage returns, and the 1-based column where each starts; `cells` and `columns`
 *  are cleared first (their storage is reused from line to line). */
void split_csv_line(const std::string& line, std::vector<std::string_view>* cells, std::vector<int>* columns) {
  cells->clear();
  columns->clear();
  const std::string_view text(line);
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = text.find(',', start);
    columns->push_back(static_cast<int>(start) + 1);
    std::string_view cell = text.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    while (!cell.empty() && (cell.back() == '\r' || cell.back() == ' ')) cell.remove_suffix(1);
    while (!cell.empty() && cell.front() == ' ') cell.remove_prefix(1);
    cells->push_back(cell);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
}

/** Reads a cell that is a number as strtod reads it (the whole cell, in range; a cell that
 *  underflows or overflows is not a number). `cell` is a view into a NUL-terminated line, and the
 *  character after it, if any, is a space, a carriage return or a comma. */
bool parse_number(std::string_view cell, double* value) {
  if (cell.empty()) return false;
  // The common case without strtod's cost: the same correctly rounded value where from_chars reads
  // the whole cell to a normal number or zero; anything else (a leading '+', hexadecimal, a
  // subnormal value, out of range) is left to strtod.
  const auto [end, error] = std::from_chars(cell.data(), cell.data() + cell.size(), *value);
  if (error == std::errc() && end == cell.data() + cell.size() &&
      (*value == 0 || std::fabs(*value) >= std::numeric_limits<double>::min())) {
    return true;
  }
  char* stop = nullptr;
  errno = 0;
  *value = std::strtod(cell.data(), &stop);
  return stop == cell.data() + cell.size() && errno != ERANGE;
}

/** The lines of an opened file, read in chunks of 64 KiB; a line is at most kMaxLine bytes and the
 *  file at most FileLimits::trajectory (checked again while reading, should it grow). */
class LineReader {
 public:
  static constexpr std::size_t kMaxLine = std::size_t{1} << 20;

  LineReader(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  ~LineReader() { ::close(fd_); }
  LineReader(const LineReader&) = delete;
  LineReader& operator=(const LineReader&) = delete;

  /** The next line (without its '\n') in `line`; false at the end of the file. */
  bool next(std::string* line, long number) {
    line->clear();
    for (;;) {
      if (at_ == end_) {
        if (done_) return !line->empty();
        end_ = pardel::read_some(fd_, buffer_, sizeof buffer_, path_, "trajectory file");
        at_ = 0;
        total_ += end_;
        if (total_ > pardel::FileLimits::trajectory)
          throw std::runtime_error(fmt::format("{}: error: grew past the limit of {} bytes for a trajectory file "
                                               "while read", path_, pardel::FileLimits::trajectory));
        if (end_ == 0) {
          done_ = true;
          return !line->empty();
        }
      }
      const char* from = buffer_ + at_;
      const char* newline = static_cast<const char*>(std::memchr(from, '\n', end_ - at_));
      const std::size_t n = newline ? static_cast<std::size_t>(newline - from) : end_ - at_;
      if (line->size() + n > kMaxLine)
        throw std::runtime_error(fmt::format("{}:{}:1: error: line {} is longer than 1 MiB; a trajectory file has "
                                             "one node per line",
                                             path_, number, number));
      line->append(from, n);
      at_ += n + (newline ? 1 : 0);
      if (newline) return true;
    }
  }

 private:
  int fd_;
  std::string path_;
  char buffer_[1 << 16];
  std::size_t at_ = 0, end_ = 0, total_ = 0;
  bool done_ = false;
};

}  // namespace

Trajectory read_trajectory_csv(const std::string& path, const pardel_model& model) {
  // A regular file of at most FileLimits::trajectory bytes, read line by line (never whole).
  std::unique_ptr<LineReader> in;
  try {
    in = std::make_unique<LineReader>(
        pardel::open_regular_file(path, pardel::FileLimits::trajectory, "trajectory file"), path);
  } catch (const pardel::FileError& error) {
    throw std::runtime_error(error.what());
  }
  auto fail = [&](long line, int col, const std::string& what) {
    return std::runtime_error(fmt::format("{}:{}:{}: error: {}", path, line, col, what));
  };
  std::string line;
  if (!in->next(&line, 1)) throw fail(1, 1, "empty file; expected a header row k,t,...");
  std::vector<std::string_view> header_cells;
  std::vector<int> header_cols;
  split_csv_line(line, &header_cells, &header_cols);
  const std::vector<std::string> header(header_cells.begin(), header_cells.end());
  // The node index and the time are the first columns named k and t; every other column is found
  // by its name, which must be unique: a coordinate named k or t (trajectory_csv writes k,t,k,...)
  // is the second column of that name, and any other repeated name is refused.
  const std::vector<std::string> state_names = state_column_names(model);
  auto is_state = [&](const std::string& name) {
    return std::find(state_names.begin(), state_names.end(), name) != state_names.end();
  };
  int col_k = -1, col_t = -1;
  std::map<std::string, int> named;
  for (std::size_t c = 0; c < header.size(); ++c) {
    const std::string& name = header[c];
    if (name == "k" && col_k < 0) {
      col_k = static_cast<int>(c);
    } else if (name == "t" && col_t < 0) {
      col_t = static_cast<int>(c);
    } else if (!name.empty()) {
      if (named.count(name) || ((name == "k" || name == "t") && !is_state(name))) {
        throw fail(1, header_cols[c], fmt::format("duplicate column '{}'", name));
      }
      named[name] = static_cast<int>(c);
    }
  }
  if (col_k < 0) throw fail(1, 1, "missing column 'k'");
  if (col_t < 0) throw fail(1, 1, "missing column 't'");
  std::vector<int> state_cols;
  for (const auto& name : state_names) {
    const auto it = named.find(name);
    if (it == named.end()) throw fail(1, 1, fmt::format("missing column '{}' of model {}", name, model.name));
    state_cols.push_back(it->second);
  }
  Trajectory trajectory;
  trajectory.dim = model.dim;
  long line_number = 1;
  std::vector<std::string_view> cells;
  std::vector<int> cols;
  while (in->next(&line, line_number + 1)) {
    ++line_number;
    if (line.empty() || line == "\r") continue;
    split_csv_line(line, &cells, &cols);
    if (cells.size() != header.size()) {
      throw fail(line_number, 1, fmt::format("{} cells, expected {} as in the header", cells.size(), header.size()));
    }
    auto number = [&](int c) {
      double v = 0;
      if (!parse_number(cells[c], &v)) {
        throw fail(line_number, cols[c], fmt::format("column '{}': '{}' is not a number", header[c], cells[c]));
      }
      if (!std::isfinite(v)) {
        throw fail(line_number, cols[c], fmt::format("column '{}': value {} is not finite", header[c], cells[c]));
      }
      return v;
    };
    const double k = number(col_k);
    const long expected_k = static_cast<long>(trajectory.t.size());
    if (k != static_cast<double>(expected_k)) {
      throw fail(line_number, cols[col_k], fmt::format("k = {} out of sequence; expected {}", cells[col_k], expected_k));
    }
    trajectory.t.push_back(number(col_t));
    for (int c : state_cols) trajectory.q.push_back(number(c));
  }
  if (trajectory.t.size() < 3) {
    throw fail(line_number, 1, fmt::format("{} nodes; a trajectory needs at least 3 (N >= 2)", trajectory.t.size()));
  }
  trajectory.N = static_cast<int>(trajectory.t.size()) - 1;
  return trajectory;
}

std::string write_temporary(const std::string& path, const std::string& content) {
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw std::runtime_error(fmt::format("{}: cannot write: {}", tmp, std::strerror(errno)));
  const std::size_t written = std::fwrite(content.data(), 1, content.size(), f);
  const bool ok = written == content.size() && std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0;
  const int err = errno;
  if (std::fclose(f) != 0 || !ok) {
    std::remove(tmp.c_str());
    throw std::runtime_error(fmt::format("{}: cannot write: {}", tmp, std::strerror(err)));
  }
  return tmp;
}

void rename_into_place(const std::string& temporary, const std::string& path) {
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(temporary.c_str());
    throw std::runtime_error(fmt::format("{}: cannot rename into place: {}", path, std::strerror(err)));
  }
}

void write_file_atomic(const std::string& path, const std::string& content) {
  rename_into_place(write_temporary(path, content), path);
}

void remove_stale_temporaries(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  const std::string prefix = target.filename().string() + ".tmp.";
  std::error_code ec;
  fs::directory_iterator it(target.parent_path().empty() ? fs::path(".") : target.parent_path(), ec);
  for (; !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string digits = name.substr(prefix.size());
    if (digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(digits));
    if (pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue;  // its writer may still run
    std::error_code ignored;
    fs::remove(it->path(), ignored);
  }
}

namespace {

/** Whether two values agree to 1e-9 of the larger, or of 1. */
bool agree(double a, double b) { return std::fabs(a - b) <= 1e-9 * std::max({1.0, std::fabs(a), std::fabs(b)}); }

/** fit_to_path's reason; `own_grid`: the scene's solve chooses its grid. */
std::string problem_mismatch(const Problem& problem, const Trajectory& trajectory, const pardel_model& model,
                             bool own_grid) {
  const std::size_t d = static_cast<std::size_t>(trajectory.dim);
  if (trajectory.N < 1 || problem.q0.size() != d || problem.qN.size() != d || trajectory.q.size() < 2 * d) return "";
  const std::vector<std::string> names = state_column_names(model);
  const auto name = [&names](std::size_t a) { return a < names.size() ? names[a] : std::to_string(a); };
  const auto node = [&](int k) { return trajectory.q.data() + static_cast<std::size_t>(k) * d; };
  for (int end = 0; end < 2; ++end) {
    const double* at = node(end == 0 ? 0 : trajectory.N);
    const std::vector<double>& boundary = end == 0 ? problem.q0 : problem.qN;
    for (std::size_t a = 0; a < d; ++a) {
      if (agree(at[a], boundary[a])) continue;
      return fmt::format("node {} has {} = {}, the scene's boundary.{} has {} = {}: the trajectory is a path of "
                         "another boundary-value problem",
                         end == 0 ? 0 : trajectory.N, name(a), at[a], end == 0 ? "q0" : "qN", name(a), boundary[a]);
    }
  }
  // Node times: the scene's grid at this N; on a grid of the path's own (an adaptive scene's) or
  // under a clock (whose placement the solve updates only every so many steps) t0 first,
  // increasing, and t0 + T last except under free_final_time.
  const std::size_t n1 = static_cast<std::size_t>(trajectory.N) + 1;
  if (trajectory.t.size() == n1) {
    const auto other_times = [&](std::size_t k, double wanted, const std::string& why) {
      return fmt::format("node {} has t = {}, the scene places it at t = {} ({}): the trajectory lies on other node "
                         "times",
                         k, trajectory.t[k], wanted, why);
    };
    if (problem.clock == ClockMode::none && !own_grid) {
      if (!problem.times.empty() && problem.times.size() != n1)
        return fmt::format("the trajectory has N = {} intervals, the scene's grid.times gives {}", trajectory.N,
                           problem.times.size() - 1);
      const std::vector<double> times = grid_times(problem, trajectory.N);
      for (std::size_t k = 0; k < n1 && k < times.size(); ++k)
        if (!agree(trajectory.t[k], times[k]))
          return other_times(k, times[k],
                             problem.times.empty()
                                 ? fmt::format("grid.t0 = {}, grid.T = {}, N = {}", problem.t0, problem.T, trajectory.N)
                                 : std::string("grid.times"));
    } else {
      if (!agree(trajectory.t[0], problem.t0)) return other_times(0, problem.t0, "grid.t0");
      if (problem.clock != ClockMode::free_final_time && !agree(trajectory.t[n1 - 1], problem.t0 + problem.T))
        return other_times(n1 - 1, problem.t0 + problem.T,
                           problem.clock == ClockMode::none ? "grid.t0 + grid.T"
                                                            : "grid.t0 + grid.T under the fixed_total_time clock");
      for (std::size_t k = 1; k < n1; ++k)
        if (!(trajectory.t[k] > trajectory.t[k - 1]))
          return fmt::format("node {} has t = {}, not after node {}'s t = {}: node times increase", k,
                             trajectory.t[k], k - 1, trajectory.t[k - 1]);
    }
  }
  // Knots: each on a node, the node's coordinates the knot's.
  for (std::size_t a = 0; a < problem.knots.size(); ++a) {
    const Knot& knot = problem.knots[a];
    int k = -1;
    for (int j = 1; j < trajectory.N && k < 0 && trajectory.t.size() == n1; ++j)
      if (agree(trajectory.t[static_cast<std::size_t>(j)], knot.t)) k = j;
    if (k < 0)
      return fmt::format("the scene's knot {} at t = {} is on no interior node of the trajectory (N = {}): the "
                         "trajectory is a path of another problem",
                         a, knot.t, trajectory.N);
    for (std::size_t i = 0; i < knot.q.size() && i < d; ++i) {
      if (agree(node(k)[i], knot.q[i])) continue;
      return fmt::format("node {} (t = {}) has {} = {}, the scene's knot {} has {} = {}: the trajectory misses the "
                         "knot",
                         k, trajectory.t[static_cast<std::size_t>(k)], name(i), node(k)[i], a, name(i), knot.q[i]);
    }
  }
  return "";
}

}  // namespace

std::string fit_to_path(Scene& scene, const Trajectory& trajectory) {
  const bool own_grid = scene.options.accuracy > 0;  // an adaptive scene: the path's nodes are its grid
  std::string mismatch = problem_mismatch(scene.problem, trajectory, *scene.model, own_grid);
  if (!mismatch.empty()) return mismatch;
  scene.problem.N = trajectory.N;
  if (own_grid && scene.problem.clock == ClockMode::none) scene.problem.times = trajectory.t;
  return "";
}

}  // namespace pardel::app
