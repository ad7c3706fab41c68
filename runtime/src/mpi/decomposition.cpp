// The node decomposition of a distributed solve: layouts, halo exchange and rank-independent reductions.
#include "decomposition.hpp"

#include <algorithm>
#include <cstddef>

namespace pardel::mpi::detail {

Layout make_layout(int N, int ranks, int rank) {
  Layout layout;
  layout.N = N;
  layout.ranks = ranks;
  layout.rank = rank;
  const NodeRange range = owned_nodes(N, ranks, rank);
  layout.first = range.first;
  layout.last = range.last;
  layout.lo = layout.has_left() ? range.first - 1 : range.first;
  layout.hi = layout.has_right() ? range.last + 1 : range.last;
  return layout;
}

void exchange_halos(const Layout& layout, double* local, int dim, MPI_Comm comm) {
  const int left = layout.has_left() ? layout.rank - 1 : MPI_PROC_NULL;
  const int right = layout.has_right() ? layout.rank + 1 : MPI_PROC_NULL;
  const std::size_t d = static_cast<std::size_t>(dim);
  double* first_owned = local + static_cast<std::size_t>(layout.local(layout.first)) * d;
  double* last_owned = local + static_cast<std::size_t>(layout.local(layout.last)) * d;
  double* left_halo = local;  // node lo (only written with a left neighbour)
  double* right_halo = local + static_cast<std::size_t>(layout.local(layout.hi)) * d;
  // Rightwards: my last owned node becomes the right neighbour's left halo.
  MPI_Sendrecv(last_owned, dim, MPI_DOUBLE, right, 101, left_halo, dim, MPI_DOUBLE, left, 101, comm,
               MPI_STATUS_IGNORE);
  // Leftwards: my first owned node becomes the left neighbour's right halo.
  MPI_Sendrecv(first_owned, dim, MPI_DOUBLE, left, 102, right_halo, dim, MPI_DOUBLE, right, 102, comm,
               MPI_STATUS_IGNORE);
}

double ordered_sum(const Layout& layout, const double* values, int n, MPI_Comm comm) {
  double s = 0;
  if (layout.has_left()) MPI_Recv(&s, 1, MPI_DOUBLE, layout.rank - 1, 103, comm, MPI_STATUS_IGNORE);
  for (int i = 0; i < n; ++i) s += values[i];
  if (layout.has_right()) MPI_Send(&s, 1, MPI_DOUBLE, layout.rank + 1, 103, comm);
  MPI_Bcast(&s, 1, MPI_DOUBLE, layout.ranks - 1, comm);
  return s;
}

double max_all(double value, MPI_Comm comm) {
  double out = 0;
  MPI_Allreduce(&value, &out, 1, MPI_DOUBLE, MPI_MAX, comm);
  return out;
}

int min_all(int value, MPI_Comm comm) {
  int out = 0;
  MPI_Allreduce(&value, &out, 1, MPI_INT, MPI_MIN, comm);
  return out;
}

bool all_true(bool value, MPI_Comm comm) {
  int in = value ? 1 : 0, out = 0;
  MPI_Allreduce(&in, &out, 1, MPI_INT, MPI_MIN, comm);
  return out == 1;
}

void broadcast_text(std::string& text, int root, MPI_Comm comm) {
  int length = static_cast<int>(text.size());
  MPI_Bcast(&length, 1, MPI_INT, root, comm);
  text.resize(static_cast<std::size_t>(length));
  MPI_Bcast(text.data(), length, MPI_CHAR, root, comm);
}

}  // namespace pardel::mpi::detail
