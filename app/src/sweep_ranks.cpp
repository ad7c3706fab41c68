// Sweeps over the ranks of an MPI run: each rank solves its share of the variants, and the results,
// packed as bytes, are gathered on rank 0 in variant order (see sweep.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstring>
#include <stdexcept>

#include "pardel/app/sweep.hpp"

#ifdef PARDEL_HAVE_MPI
#include <mpi.h>
#endif

namespace pardel::app {
namespace {

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

}  // namespace

std::vector<VariantResult> run_variants_over_ranks(const Sweep& sweep, int threads, int rank, int size,
                                                   const std::function<void(int, int)>& on_done,
                                                   const std::atomic<bool>* stop, bool keep_trajectories) {
  const int total = sweep.variant_count();
  const int mine = rank < total ? (total - rank + size - 1) / size : 0;
  // Results grow as variants finish (nothing is reserved for 10^7 variants up front), and once
  // `stop` is set no further variant is started or listed.
  std::vector<VariantResult> local;
  // One rank solves in variant order, so the representatives found here are group_solutions'.
  const bool prune = !keep_trajectories && size <= 1;
  std::vector<std::size_t> representatives;  // indices into local
  for (int id = rank; id < total; id += size) {
    if (stop && stop->load()) break;
    local.push_back(solve_variant(sweep, make_variant(sweep, id), threads, stop));
    VariantResult& result = local.back();
    if (prune && result.converged()) {
      for (const std::size_t r : representatives) {
        if (same_solution(local[r], result, sweep.grouping)) {
          result.same_as = local[r].id;
          std::vector<double>().swap(result.trajectory.t);
          std::vector<double>().swap(result.trajectory.q);
          break;
        }
      }
      if (result.same_as < 0) representatives.push_back(local.size() - 1);
    }
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
  // Each rank's results are in increasing id order; an interrupted rank sends fewer.
  std::vector<VariantResult> all;
  for (int r = 0; r < size; ++r) {
    Unpacker u(gathered.data() + displacements[r], static_cast<std::size_t>(counts[r]));
    while (!u.done()) {
      VariantResult result = unpack(u);
      if (result.id < 0 || result.id >= total || result.id % size != r) throw std::logic_error("sweep: bad variant id");
      all.push_back(std::move(result));
    }
  }
  std::sort(all.begin(), all.end(), [](const VariantResult& a, const VariantResult& b) { return a.id < b.id; });
  for (std::size_t i = 1; i < all.size(); ++i) {
    if (all[i].id == all[i - 1].id) throw std::logic_error(fmt::format("sweep: two results for variant {}", all[i].id));
  }
  return all;
#else
  throw std::logic_error("sweep: several ranks in a build without MPI");
#endif
}

}  // namespace pardel::app
