// Throughput of pardel's generated `full` kernels against the SymPy peer's C code, on one core.
//
// Built and run by tools/codegen_peer/run_peer.py, which writes the registry (peer_registry.cpp:
// the list of PeerEntry) and compiles this file, the registry, pardel's generated model sources
// and the SymPy peer's C files with the same flags. For each entry it draws a buffer of random
// interval inputs (fixed seed) in the entry's sampling box, keeps those where pardel's outputs are
// finite, and times both kernels over the same buffer, alternating rounds so that machine load
// affects both alike; time is the thread's CPU time and the best round of each is reported.
// Every call writes its own slot of an output buffer that is read afterwards (the two kernels'
// results are compared), so no call can be optimized away. Output: one JSON object per line.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <time.h>

#include "pardel/kernel_abi.h"
#include "peer_bench.hpp"

namespace {

struct Inputs {
  int count = 0;
  int dim = 0;
  std::vector<double> h, t0, t1, q0, q1;
};

struct Outputs {
  explicit Outputs(int count, int m)
      : m(m), ld(count), d1(count * m), d2(count * m), d11(count * m * m), d12(count * m * m), d22(count * m * m) {}
  int m;
  std::vector<double> ld, d1, d2, d11, d12, d22;
};

void call(pardel_full_kernel kernel, const Inputs& in, int i, const double* p, Outputs& out) {
  const int m = in.dim;
  kernel(in.h[i], in.t0[i], in.t1[i], &in.q0[i * m], &in.q1[i * m], p, &out.ld[i], &out.d1[i * m], &out.d2[i * m],
         &out.d11[i * m * m], &out.d12[i * m * m], &out.d22[i * m * m]);
}

bool finite_at(const Outputs& out, int i) {
  const int m = out.m;
  auto ok = [](const double* v, int n) {
    for (int k = 0; k < n; ++k)
      if (!std::isfinite(v[k])) return false;
    return true;
  };
  return std::isfinite(out.ld[i]) && ok(&out.d1[i * m], m) && ok(&out.d2[i * m], m) && ok(&out.d11[i * m * m], m * m) &&
         ok(&out.d12[i * m * m], m * m) && ok(&out.d22[i * m * m], m * m);
}

Inputs draw_inputs(const PeerEntry& e, pardel_full_kernel kernel, const double* p, int count) {
  const int m = e.dim, n = e.ncoords;
  Inputs in;
  in.dim = m;
  std::mt19937_64 rng(20240601);
  auto uniform = [&rng](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  Outputs probe(1, m);
  for (int tries = 0; in.count < count && tries < 100 * count; ++tries) {
    const double h = uniform(e.h_lo, e.h_hi), t0 = uniform(e.t_lo, e.t_hi), t1 = t0 + h * uniform(0.5, 2.0);
    std::vector<double> a(m), b(m);
    for (int k = 0; k < m; ++k) {
      const bool position = k < n;
      a[k] = position ? uniform(e.coord_lo, e.coord_hi) : uniform(e.deriv_lo, e.deriv_hi);
      b[k] = position ? uniform(e.coord_lo, e.coord_hi) : uniform(e.deriv_lo, e.deriv_hi);
      if (position) b[k] = a[k] + h * (b[k] - a[k]) / 3;  // as in check_kernels.py
    }
    Inputs one;
    one.count = 1;
    one.dim = m;
    one.h = {h};
    one.t0 = {t0};
    one.t1 = {t1};
    one.q0 = a;
    one.q1 = b;
    call(kernel, one, 0, p, probe);
    if (!finite_at(probe, 0)) continue;
    in.h.push_back(h);
    in.t0.push_back(t0);
    in.t1.push_back(t1);
    in.q0.insert(in.q0.end(), a.begin(), a.end());
    in.q1.insert(in.q1.end(), b.begin(), b.end());
    ++in.count;
  }
  return in;
}

/** CPU seconds of this thread: robust to other processes sharing the core. */
double thread_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/** Thread CPU seconds for `reps` passes over the buffer. */
double time_passes(pardel_full_kernel kernel, const Inputs& in, const double* p, Outputs& out, int reps) {
  const double start = thread_seconds();
  for (int r = 0; r < reps; ++r)
    for (int i = 0; i < in.count; ++i) call(kernel, in, i, p, out);
  return thread_seconds() - start;
}

/** Normwise relative difference of the two kernels' outputs, worst block over all points. */
double max_relative_difference(const Outputs& a, const Outputs& b, int count) {
  const int m = a.m;
  double worst = 0;
  auto block = [&worst](const double* x, const double* y, int n) {
    double diff = 0, scale = 0;
    for (int k = 0; k < n; ++k) {
      diff = std::max(diff, std::fabs(x[k] - y[k]));
      scale = std::max(scale, std::fabs(y[k]));
    }
    worst = std::max(worst, scale > 0 ? diff / scale : diff);
  };
  for (int i = 0; i < count; ++i) {
    block(&a.ld[i], &b.ld[i], 1);
    block(&a.d1[i * m], &b.d1[i * m], m);
    block(&a.d2[i * m], &b.d2[i * m], m);
    block(&a.d11[i * m * m], &b.d11[i * m * m], m * m);
    block(&a.d12[i * m * m], &b.d12[i * m * m], m * m);
    block(&a.d22[i * m * m], &b.d22[i * m * m], m * m);
  }
  return worst;
}

}  // namespace

int main(int argc, char** argv) {
  const double min_seconds = argc > 1 ? std::atof(argv[1]) : 0.2;  // per timed round
  const int rounds = argc > 2 ? std::atoi(argv[2]) : 5;
  const int count = 512;
  for (int e = 0; e < kPeerEntryCount; ++e) {
    const PeerEntry& entry = kPeerEntries[e];
    const pardel_model* model = entry.model;
    pardel_full_kernel ours = nullptr;
    for (int d = 0; d < model->ndiscretizations; ++d)
      if (std::strcmp(model->discretizations[d].name, entry.disc) == 0) ours = model->discretizations[d].full;
    if (!ours) {
      std::fprintf(stderr, "error: model %s has no discretization %s\n", model->name, entry.disc);
      return 1;
    }
    const double* p = model->param_defaults;
    const Inputs in = draw_inputs(entry, ours, p, count);
    if (in.count < count) {
      std::fprintf(stderr, "error: %s %s: only %d finite points in the sampling box\n", model->name, entry.disc,
                   in.count);
      return 1;
    }
    Outputs out_ours(in.count, in.dim), out_peer(in.count, in.dim);
    // Calibrate the number of passes to about min_seconds per round.
    int reps = 1;
    while (time_passes(ours, in, p, out_ours, reps) < min_seconds / 4) reps *= 2;
    reps *= 4;
    double best_ours = 1e300, best_peer = 1e300;
    for (int r = 0; r < rounds; ++r) {
      best_ours = std::min(best_ours, time_passes(ours, in, p, out_ours, reps));
      best_peer = std::min(best_peer, time_passes(entry.peer, in, p, out_peer, reps));
    }
    const double evals = static_cast<double>(reps) * in.count;
    std::printf("{\"model\": \"%s\", \"disc\": \"%s\", \"pardel_evals_per_s\": %.4g, \"peer_evals_per_s\": %.4g, "
                "\"max_rel_diff\": %.3g}\n",
                model->name, entry.disc, evals / best_ours, evals / best_peer,
                max_relative_difference(out_peer, out_ours, in.count));
    std::fflush(stdout);
  }
  return 0;
}
