/**
 * @file batch_device.cuh
 * The device side of solve_batch_cuda for one model and discretization (Kernel, dimension D): the
 * sweep kernel and the launch loop, which looks at the count of running problems every
 * check_every sweeps and at nothing else. A sweep is one launch: each problem has a few blocks
 * (enough to fill the device once), whose threads take the problem's nodes in turn, one node at a
 * time; each block reduces what its nodes found and folds it into the problem's record with one
 * atomic per value, and the problem's last block to arrive makes the decision
 * (batch_sweep::decide). And Newton (batch_newton.hpp), one thread per problem over the batch's
 * interleaved arrays, check_every iterations per launch. Included by the generated per-model
 * registration sources (runtime/cuda/CMakeLists.txt).
 */
#ifndef PARDEL_CUDA_BATCH_DEVICE_CUH
#define PARDEL_CUDA_BATCH_DEVICE_CUH

#include <cuda_runtime.h>

#include <cub/block/block_reduce.cuh>

#include "batch_newton.hpp"
#include "batch_sweep.hpp"
#include "device_registry.hpp"

namespace pardel::cuda_detail {

namespace bs = pardel::batch_sweep;

constexpr int kBlock = 128;
#ifndef PARDEL_CUDA_MIN_BLOCKS
#define PARDEL_CUDA_MIN_BLOCKS 1
#endif

template <int D>
struct MergeStats {
  __device__ bs::Stats<D> operator()(const bs::Stats<D>& a, const bs::Stats<D>& b) const {
    bs::Stats<D> c = a;
    bs::merge(c, b);
    return c;
  }
};

/** Non-negative doubles order as their bit patterns: a maximum by atomicMax on the bits. */
__device__ inline void atomic_larger(double* at, double v) {
  if (v > 0) atomicMax(reinterpret_cast<unsigned long long*>(at), static_cast<unsigned long long>(__double_as_longlong(v)));
}
/** -1 (no node) is the largest unsigned value: the first node by atomicMin on the bits. */
__device__ inline void atomic_first(int* at, int v) {
  if (v >= 0) atomicMin(reinterpret_cast<unsigned int*>(at), static_cast<unsigned int>(v));
}

/** A problem's record as the other blocks' atomics left it (read past the L1 cache). */
template <int D>
__device__ inline bs::Stats<D> load_folded(const bs::Stats<D>* s) {
  bs::Stats<D> r;
  r.residual = __ldcg(&s->residual);
  r.scale = __ldcg(&s->scale);
  r.qmax = __ldcg(&s->qmax);
  for (int i = 0; i < D; ++i) {
    r.comp_residual[i] = __ldcg(&s->comp_residual[i]);
    r.comp_scale[i] = __ldcg(&s->comp_scale[i]);
  }
  r.bad_residual = __ldcg(&s->bad_residual);
  r.singular = __ldcg(&s->singular);
  r.bad_value = __ldcg(&s->bad_value);
  return r;
}

/**
 * Sweep `it` (reads iterate it from `in`, writes iterate it+1 to `out`): blocks_per_problem
 * blocks per problem, whose threads take nodes part * kBlock + threadIdx.x, then the same plus
 * blocks_per_problem * kBlock, and so on. `arrived` counts, per problem, the blocks that have
 * folded their findings; the last one decides, clears the record and the count for the next
 * sweep, and takes a stopped problem off `running`.
 */
template <class Kernel, int D>
__global__ void __launch_bounds__(kBlock, PARDEL_CUDA_MIN_BLOCKS) sweep_kernel(int N, int blocks_per_problem, long it,
                                                       const double* __restrict__ in, double* __restrict__ out,
                                                       const double* __restrict__ t, const double* __restrict__ h,
                                                       const double* __restrict__ p, int np, bs::Settings set,
                                                       bs::ProblemState<D>* state, bs::Stats<D>* stats, int* arrived,
                                                       int* running) {
  const int b = blockIdx.x / blocks_per_problem;
  if (state[b].status != bs::running) return;  // the whole block: the reduction below needs all or none
  const long part = blockIdx.x % blocks_per_problem;
  const long nodes = static_cast<long>(N) + 1, stride = static_cast<long>(blocks_per_problem) * kBlock;
  const double* q = in + b * nodes * D;
  double* o = out + b * nodes * D;
  const double* pb = p + static_cast<long>(b) * np;
  bs::Stats<D> mine;
  bs::clear(mine);
  for (long k = part * kBlock + threadIdx.x; k < nodes; k += stride) {
    if (k == 0 || k == N) {
      for (int i = 0; i < D; ++i) o[k * D + i] = q[k * D + i];
      continue;
    }
    bs::Interval<D> left, right;
    Kernel::sweep(h[k - 1], t[k - 1], t[k], q + (k - 1) * D, q + k * D, pb, left.D1, left.D2, left.D11, left.D22);
    Kernel::sweep(h[k], t[k], t[k + 1], q + k * D, q + (k + 1) * D, pb, right.D1, right.D2, right.D11, right.D22);
    bs::update_node<Kernel, D>(static_cast<int>(k), q, t, h, pb, left, right, set, o + k * D, mine);
  }
  using Reduce = cub::BlockReduce<bs::Stats<D>, kBlock>;
  __shared__ typename Reduce::TempStorage scratch;
  const bs::Stats<D> all = Reduce(scratch).Reduce(mine, MergeStats<D>());
  if (threadIdx.x != 0) return;
  bs::Stats<D>& s = stats[b];
  atomic_larger(&s.residual, all.residual);
  atomic_larger(&s.scale, all.scale);
  atomic_larger(&s.qmax, all.qmax);
  for (int i = 0; i < D; ++i) {
    atomic_larger(&s.comp_residual[i], all.comp_residual[i]);
    atomic_larger(&s.comp_scale[i], all.comp_scale[i]);
  }
  atomic_first(&s.bad_residual, all.bad_residual);
  atomic_first(&s.singular, all.singular);
  atomic_first(&s.bad_value, all.bad_value);
  __threadfence();  // this block's folds before its arrival
  if (atomicAdd(&arrived[b], 1) != blocks_per_problem - 1) return;
  // The problem's last block: every block's folds are in the record.
  __threadfence();
  const bs::Stats<D> folded = load_folded(&s);
  bs::ProblemState<D> st = state[b];
  bs::decide(st, folded, it, set);
  state[b] = st;
  bs::clear(s);
  arrived[b] = 0;
  if (st.status != bs::running) atomicSub(running, 1);
}

template <int D>
__global__ void start_kernel(int B, bs::ProblemState<D>* state, bs::Stats<D>* stats, const int* invalid, int* arrived) {
  const int b = blockIdx.x * blockDim.x + threadIdx.x;
  if (b >= B) return;
  bs::start(state[b]);
  if (invalid[b]) state[b].status = bs::not_started;
  bs::clear(stats[b]);
  arrived[b] = 0;
}

/** Blocks per problem: `wanted` if given (at most one per kBlock nodes), else as many as fill
 *  the device once with the whole batch. */
template <class Kernel, int D>
int blocks_per_problem(int B, long nodes, int wanted) {
  const long most = (nodes + kBlock - 1) / kBlock;
  if (wanted > 0) return static_cast<int>(wanted < most ? wanted : most);
  int device = 0, sms = 1, per_sm = 1;
  cudaGetDevice(&device);
  cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device);
  cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, sweep_kernel<Kernel, D>, kBlock, 0);
  const long resident = static_cast<long>(sms > 0 ? sms : 1) * (per_sm > 0 ? per_sm : 1);
  const long fill = (resident + B - 1) / B;
  return static_cast<int>(fill < most ? fill : most);
}

/** Device buffers, freed on every path. */
struct Buffers {
  void* held[8] = {};
  int n = 0;
  ~Buffers() {
    for (int i = 0; i < n; ++i) cudaFree(held[i]);
  }
  template <class T>
  T* get(std::size_t count, cudaError_t& err) {
    void* b = nullptr;
    if (err == cudaSuccess) err = cudaMalloc(&b, sizeof(T) * (count > 0 ? count : 1));
    if (err != cudaSuccess) return nullptr;
    held[n++] = b;
    return static_cast<T*>(b);
  }
};

/** The events of a batch: start, iterations begin, iterations end, copies back done; destroyed on
 *  every path. */
struct Events {
  cudaEvent_t e[4];
  Events() {
    for (cudaEvent_t& x : e) cudaEventCreate(&x);
  }
  ~Events() {
    for (cudaEvent_t x : e) cudaEventDestroy(x);
  }
  /** The upload, iteration and download times into `result` (after e[3] was recorded). */
  void times(DeviceBatchResult& result) {
    cudaEventSynchronize(e[3]);
    float ms[3] = {0, 0, 0};
    for (int i = 0; i < 3; ++i) cudaEventElapsedTime(&ms[i], e[i], e[i + 1]);
    result.upload = ms[0] * 1e-3;
    result.sweeps = ms[1] * 1e-3;
    result.download = ms[2] * 1e-3;
  }
};

/** The batch's guesses (into q: B (N+1) D values), grid, params and invalid flags to the device,
 *  and the count of problems to run (into *running and *running_on_device). */
template <int D>
cudaError_t upload(const DeviceBatch& in, double* q, double* t, double* h, double* p, int* invalid,
                   int* running_on_device, int* running) {
  const std::size_t nodes = static_cast<std::size_t>(in.N) + 1;
  *running = 0;
  for (int b = 0; b < in.B; ++b) *running += in.invalid[b] ? 0 : 1;
  cudaError_t err = cudaMemcpy(q, in.q, sizeof(double) * static_cast<std::size_t>(in.B) * nodes * D,
                               cudaMemcpyHostToDevice);
  if (err == cudaSuccess) err = cudaMemcpy(t, in.t, sizeof(double) * nodes, cudaMemcpyHostToDevice);
  if (err == cudaSuccess) err = cudaMemcpy(h, in.h, sizeof(double) * in.N, cudaMemcpyHostToDevice);
  if (err == cudaSuccess && in.np > 0)
    err = cudaMemcpy(p, in.p, sizeof(double) * static_cast<std::size_t>(in.B) * in.np, cudaMemcpyHostToDevice);
  if (err == cudaSuccess) err = cudaMemcpy(invalid, in.invalid, sizeof(int) * in.B, cudaMemcpyHostToDevice);
  if (err == cudaSuccess) err = cudaMemcpy(running_on_device, running, sizeof(int), cudaMemcpyHostToDevice);
  return err;
}

/** A problem's record as the host reads it. */
template <int D>
void read_record(const bs::ProblemState<D>& s, ProblemRecord& r) {
  r.status = s.status;
  r.iterations = s.iterations;
  r.node = s.node;
  r.unresolved = s.unresolved;
  r.residual = s.residual;
  r.scale = s.scale;
  r.target = s.target;
  r.r_initial = s.r_initial;
  r.comp_residual.assign(s.comp_residual, s.comp_residual + D);
  r.comp_target.assign(s.comp_target, s.comp_target + D);
}

/** The launch loop for one model and discretization (a DeviceRunner, device_registry.hpp). */
template <class Kernel, int D>
std::string run_batch(const DeviceBatch& in, DeviceBatchResult& result) {
  const int B = in.B, N = in.N;
  const long nodes = static_cast<long>(N) + 1;
  const std::size_t values = static_cast<std::size_t>(B) * static_cast<std::size_t>(nodes) * D;
  cudaError_t err = cudaSuccess;
  Buffers buf;
  double* q0 = buf.get<double>(values, err);
  double* q1 = buf.get<double>(values, err);
  double* t = buf.get<double>(static_cast<std::size_t>(nodes), err);
  double* h = buf.get<double>(static_cast<std::size_t>(N), err);
  double* p = buf.get<double>(static_cast<std::size_t>(B) * in.np, err);
  auto* state = buf.get<bs::ProblemState<D>>(static_cast<std::size_t>(B), err);
  auto* stats = buf.get<bs::Stats<D>>(static_cast<std::size_t>(B), err);
  int* flags = buf.get<int>(2 * static_cast<std::size_t>(B) + 1, err);  // invalid[B], the running count, arrived[B]
  if (err != cudaSuccess) return std::string("device allocation failed: ") + cudaGetErrorString(err);
  Events events;
  cudaEvent_t &e0 = events.e[0], &e1 = events.e[1], &e2 = events.e[2], &e3 = events.e[3];
  cudaEventRecord(e0);
  int running = 0;
  err = upload<D>(in, q0, t, h, p, flags, flags + B, &running);
  if (err != cudaSuccess) return std::string("copy to the device failed: ") + cudaGetErrorString(err);
  const int per_problem = blocks_per_problem<Kernel, D>(B, nodes, in.blocks_per_problem);
  const long blocks = static_cast<long>(per_problem) * B;
  int* arrived = flags + B + 1;
  start_kernel<D><<<(B + 127) / 128, 128>>>(B, state, stats, flags, arrived);
  cudaEventRecord(e1);
  long it = 0;
  while (running > 0) {
    for (int c = 0; c < in.check_every; ++c, ++it) {
      const double* from = it % 2 == 0 ? q0 : q1;
      double* to = it % 2 == 0 ? q1 : q0;
      sweep_kernel<Kernel, D><<<static_cast<unsigned>(blocks), kBlock>>>(N, per_problem, it, from, to, t, h, p, in.np,
                                                                          in.settings, state, stats, arrived, flags + B);
    }
    err = cudaMemcpy(&running, flags + B, sizeof(int), cudaMemcpyDeviceToHost);  // waits for the sweeps
    if (err != cudaSuccess) return std::string("a device sweep failed: ") + cudaGetErrorString(err);
    if (running > 0 && in.keep_going && !in.keep_going()) break;  // the running problems end interrupted
  }
  err = cudaGetLastError();
  if (err != cudaSuccess) return std::string("a device sweep failed: ") + cudaGetErrorString(err);
  cudaEventRecord(e2);
  std::vector<bs::ProblemState<D>> host_state(static_cast<std::size_t>(B));
  err = cudaMemcpy(host_state.data(), state, sizeof(bs::ProblemState<D>) * B, cudaMemcpyDeviceToHost);
  if (err != cudaSuccess) return std::string("copy from the device failed: ") + cudaGetErrorString(err);
  // Each problem's returned iterate is in the buffer its record names; problems still running
  // (interrupted) return the last iterate, in the buffer the next sweep would have read.
  const int last = static_cast<int>(it % 2);
  for (int b = 0; b < B && err == cudaSuccess; ++b) {
    const bs::ProblemState<D>& s = host_state[static_cast<std::size_t>(b)];
    const int which = s.status == bs::running ? last : s.answer;
    const std::size_t at = static_cast<std::size_t>(b) * static_cast<std::size_t>(nodes) * D;
    err = cudaMemcpyAsync(result.q + at, (which == 0 ? q0 : q1) + at, sizeof(double) * nodes * D,
                          cudaMemcpyDeviceToHost);
  }
  if (err == cudaSuccess) err = cudaDeviceSynchronize();
  if (err != cudaSuccess) return std::string("copy from the device failed: ") + cudaGetErrorString(err);
  cudaEventRecord(e3);
  events.times(result);
  result.sweeps_run = it;
  for (int b = 0; b < B; ++b) {
    const bs::ProblemState<D>& s = host_state[static_cast<std::size_t>(b)];
    ProblemRecord& r = result.records[static_cast<std::size_t>(b)];
    read_record(s, r);
    if (s.status == bs::running) r.iterations = it;
  }
  return "";
}

namespace bn = pardel::batch_newton;

constexpr int kNewtonBlock = 64;

/** Each problem's guess (contiguous, B (N+1) D values) into its interleaved iterate buffer 0. One
 *  thread per value. */
template <int D>
__global__ void interleave_kernel(int B, int N, const double* contiguous, double* work) {
  const long n = (static_cast<long>(N) + 1) * D;
  const long i = static_cast<long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n * B) return;
  const long b = i / n, e = i % n;
  work[e * B + b] = contiguous[i];
}

template <class Kernel, int D>
__global__ void newton_start_kernel(int B, int N, double* work, const double* __restrict__ t,
                                    const double* __restrict__ h, const double* __restrict__ p, int np,
                                    bs::Settings set, const int* invalid, bn::State<D>* state, int* running) {
  const int b = blockIdx.x * blockDim.x + threadIdx.x;
  if (b >= B) return;
  if (invalid[b]) {
    bs::start(state[b].s);
    state[b].s.status = bs::not_started;
    state[b].current = 0;
    state[b].reason = bn::none;
    return;
  }
  bn::State<D> ns;
  const bn::Arrays<D> a = bn::arrays<D>(work, N, B, b);
  bn::start<Kernel, D>(N, t, h, p + static_cast<long>(b) * np, set, a, ns);
  state[b] = ns;
  if (ns.s.status != bs::running) atomicSub(running, 1);
}

template <class Kernel, int D>
__global__ void newton_kernel(int B, int N, int count, double* work, const double* __restrict__ t,
                              const double* __restrict__ h, const double* __restrict__ p, int np, bs::Settings set,
                              bn::State<D>* state, int* running) {
  const int b = blockIdx.x * blockDim.x + threadIdx.x;
  if (b >= B || state[b].s.status != bs::running) return;
  bn::State<D> ns = state[b];
  const bn::Arrays<D> a = bn::arrays<D>(work, N, B, b);
  bn::advance<Kernel, D>(N, t, h, p + static_cast<long>(b) * np, set, a, ns, count);
  state[b] = ns;
  if (ns.s.status != bs::running) atomicSub(running, 1);
}

/** Each problem's iterate (interleaved, buffer state[b].current) back into the contiguous array. */
template <int D>
__global__ void gather_kernel(int B, int N, const double* work, const bn::State<D>* state, double* contiguous) {
  const long n = (static_cast<long>(N) + 1) * D;
  const long i = static_cast<long>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= n * B) return;
  const long b = i / n, e = i % n;
  const long buffer = state[b].current == 0 ? 0 : n;
  contiguous[i] = work[(buffer + e) * B + b];
}

/** Newton's launch loop for one model and discretization (a DeviceRunner, device_registry.hpp):
 *  the guesses interleaved, the first evaluation, then launches of check_every iterations per
 *  problem until none runs (or keep_going says stop: the running problems end interrupted). */
template <class Kernel, int D>
std::string run_newton_batch(const DeviceBatch& in, DeviceBatchResult& result) {
  const int B = in.B, N = in.N;
  const long nodes = static_cast<long>(N) + 1;
  const std::size_t values = static_cast<std::size_t>(B) * static_cast<std::size_t>(nodes) * D;
  cudaError_t err = cudaSuccess;
  Buffers buf;
  double* q = buf.get<double>(values, err);
  double* work = buf.get<double>(static_cast<std::size_t>(B) * static_cast<std::size_t>(bn::values_per_problem<D>(N)), err);
  double* t = buf.get<double>(static_cast<std::size_t>(nodes), err);
  double* h = buf.get<double>(static_cast<std::size_t>(N), err);
  double* p = buf.get<double>(static_cast<std::size_t>(B) * in.np, err);
  auto* state = buf.get<bn::State<D>>(static_cast<std::size_t>(B), err);
  int* flags = buf.get<int>(static_cast<std::size_t>(B) + 1, err);  // invalid[B], the running count
  if (err != cudaSuccess) return std::string("device allocation failed: ") + cudaGetErrorString(err);
  Events events;
  cudaEvent_t &e0 = events.e[0], &e1 = events.e[1], &e2 = events.e[2], &e3 = events.e[3];
  cudaEventRecord(e0);
  int running = 0;
  err = upload<D>(in, q, t, h, p, flags, flags + B, &running);
  if (err != cudaSuccess) return std::string("copy to the device failed: ") + cudaGetErrorString(err);
  const unsigned per_value = static_cast<unsigned>((values + 255) / 256);
  const unsigned per_problem = static_cast<unsigned>((B + kNewtonBlock - 1) / kNewtonBlock);
  interleave_kernel<D><<<per_value, 256>>>(B, N, q, work);
  cudaEventRecord(e1);
  newton_start_kernel<Kernel, D><<<per_problem, kNewtonBlock>>>(B, N, work, t, h, p, in.np, in.settings, flags, state,
                                                                flags + B);
  err = cudaMemcpy(&running, flags + B, sizeof(int), cudaMemcpyDeviceToHost);
  while (err == cudaSuccess && running > 0) {
    if (in.keep_going && !in.keep_going()) break;  // the running problems end interrupted
    newton_kernel<Kernel, D><<<per_problem, kNewtonBlock>>>(B, N, in.check_every, work, t, h, p, in.np, in.settings,
                                                            state, flags + B);
    err = cudaMemcpy(&running, flags + B, sizeof(int), cudaMemcpyDeviceToHost);  // waits for the launch
  }
  if (err == cudaSuccess) err = cudaGetLastError();
  if (err != cudaSuccess) return std::string("a device Newton iteration failed: ") + cudaGetErrorString(err);
  cudaEventRecord(e2);
  gather_kernel<D><<<per_value, 256>>>(B, N, work, state, q);
  std::vector<bn::State<D>> host_state(static_cast<std::size_t>(B));
  err = cudaMemcpy(host_state.data(), state, sizeof(bn::State<D>) * B, cudaMemcpyDeviceToHost);
  if (err == cudaSuccess) err = cudaMemcpy(result.q, q, sizeof(double) * values, cudaMemcpyDeviceToHost);
  if (err != cudaSuccess) return std::string("copy from the device failed: ") + cudaGetErrorString(err);
  cudaEventRecord(e3);
  events.times(result);
  long longest = 0;
  for (int b = 0; b < B; ++b) {
    const bn::State<D>& ns = host_state[static_cast<std::size_t>(b)];
    const bs::ProblemState<D>& s = ns.s;
    ProblemRecord& r = result.records[static_cast<std::size_t>(b)];
    read_record(s, r);
    r.reason = ns.reason;
    if (s.status != bs::not_started && s.iterations > longest) longest = s.iterations;
  }
  result.sweeps_run = longest;
  return "";
}

}  // namespace pardel::cuda_detail

#endif  // PARDEL_CUDA_BATCH_DEVICE_CUH
