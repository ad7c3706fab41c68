// The registry that run_peer.py writes for peer_bench.cpp: which kernels to compare and where to
// sample their inputs.
#ifndef PARDEL_PEER_BENCH_HPP
#define PARDEL_PEER_BENCH_HPP

#include "pardel/kernel_abi.h"

struct PeerEntry {
  const pardel_model* model;  // pardel's generated model (its `full` kernel is looked up by disc)
  const char* disc;           // discretization name as in the .lag
  pardel_full_kernel peer;    // the SymPy peer's function
  int ncoords;
  int dim;
  double coord_lo, coord_hi;  // box of the coordinates
  double deriv_lo, deriv_hi;  // box of the stored derivatives (order >= 2)
  double h_lo, h_hi;          // range of h
  double t_lo, t_hi;          // range of t0
};

extern const PeerEntry kPeerEntries[];
extern const int kPeerEntryCount;

#endif  // PARDEL_PEER_BENCH_HPP
