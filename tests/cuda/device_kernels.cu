// The device-kernel check (compiled as CUDA with relocatable device code): the generated kernels of
// some bundled models, declared PARDEL_HD in their generated headers, are called by name from one
// per-interval function that runs in a host loop and in a device kernel.
#include "device_kernels.hpp"

#include <cuda_runtime.h>

#include "bratu.hpp"
#include "fuel_nav.hpp"
#include "min_snap.hpp"
#include "zermelo_tv.hpp"

namespace pardel_cuda_check {
namespace {

#define PARDEL_CHECK_MODEL(Type, model_symbol, full_kernel)                                              \
  struct Type {                                                                                          \
    static const pardel_model& model() { return model_symbol; }                                          \
    PARDEL_HD static void full(double h, double t0, double t1, const double* q0, const double* q1,        \
                               const double* p, double* Ld, double* D1, double* D2, double* D11,         \
                               double* D12, double* D22) {                                               \
      full_kernel(h, t0, t1, q0, q1, p, Ld, D1, D2, D11, D12, D22);                                      \
    }                                                                                                    \
  };
PARDEL_CHECK_MODEL(Bratu, bratu_model, bratu_trapezoid_full)
PARDEL_CHECK_MODEL(FuelNav, fuel_nav_model, fuel_nav_trapezoid_full)
PARDEL_CHECK_MODEL(MinSnap, min_snap_model, min_snap_hermite_gauss_s_4_full)
PARDEL_CHECK_MODEL(ZermeloTv, zermelo_tv_model, zermelo_tv_trapezoid_full)
#undef PARDEL_CHECK_MODEL

/** Interval k's kernel values into out + k * values_per_interval(m): the function both paths run. */
template <class Model>
PARDEL_HD void evaluate_interval(int k, int m, const double* q, const double* t, const double* p, double* out) {
  double* o = out + static_cast<long>(k) * (1 + 2 * m + 3 * m * m);
  Model::full(t[k + 1] - t[k], t[k], t[k + 1], q + static_cast<long>(k) * m, q + static_cast<long>(k + 1) * m, p,
              o, o + 1, o + 1 + m, o + 1 + 2 * m, o + 1 + 2 * m + m * m, o + 1 + 2 * m + 2 * m * m);
}

template <class Model>
__global__ void evaluate_all(int N, int m, const double* q, const double* t, const double* p, double* out) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k < N) evaluate_interval<Model>(k, m, q, t, p, out);
}

template <class Model>
std::vector<double> host_loop(int N, const std::vector<double>& q, const std::vector<double>& t,
                              const std::vector<double>& p) {
  const int m = Model::model().dim;
  std::vector<double> out(static_cast<std::size_t>(N) * values_per_interval(m));
  for (int k = 0; k < N; ++k) evaluate_interval<Model>(k, m, q.data(), t.data(), p.data(), out.data());
  return out;
}

/** Frees its device buffers on every path. */
struct DeviceBuffers {
  std::vector<void*> held;
  ~DeviceBuffers() {
    for (void* b : held) cudaFree(b);
  }
  double* copy(const std::vector<double>& v, std::size_t at_least, cudaError_t& status) {
    void* b = nullptr;
    status = cudaMalloc(&b, sizeof(double) * std::max<std::size_t>(at_least, 1));
    if (status != cudaSuccess) return nullptr;
    held.push_back(b);
    if (!v.empty()) status = cudaMemcpy(b, v.data(), sizeof(double) * v.size(), cudaMemcpyHostToDevice);
    return static_cast<double*>(b);
  }
};

template <class Model>
bool device_run(int N, const std::vector<double>& q, const std::vector<double>& t, const std::vector<double>& p,
                std::vector<double>& out, std::string& why) {
  int devices = 0;
  cudaError_t status = cudaGetDeviceCount(&devices);
  if (status != cudaSuccess || devices == 0) {
    why = status != cudaSuccess ? std::string("no CUDA device: ") + cudaGetErrorString(status) : "no CUDA device";
    return false;
  }
  const int m = Model::model().dim;
  out.assign(static_cast<std::size_t>(N) * values_per_interval(m), 0.0);
  DeviceBuffers buffers;
  double* dq = buffers.copy(q, q.size(), status);
  double* dt = status == cudaSuccess ? buffers.copy(t, t.size(), status) : nullptr;
  double* dp = status == cudaSuccess ? buffers.copy(p, p.size(), status) : nullptr;
  double* dout = status == cudaSuccess ? buffers.copy({}, out.size(), status) : nullptr;
  if (status == cudaSuccess) {
    const int threads = 128;
    evaluate_all<Model><<<(N + threads - 1) / threads, threads>>>(N, m, dq, dt, dp, dout);
    status = cudaGetLastError();
  }
  if (status == cudaSuccess) status = cudaDeviceSynchronize();
  if (status == cudaSuccess)
    status = cudaMemcpy(out.data(), dout, sizeof(double) * out.size(), cudaMemcpyDeviceToHost);
  if (status != cudaSuccess) {
    why = std::string("CUDA: ") + cudaGetErrorString(status);
    return false;
  }
  return true;
}

/** Calls f with a value of the model's check type; false when the name is not one of them. */
template <class F>
bool visit_model(const std::string& name, F&& f) {
  if (name == "bratu") f(Bratu{});
  else if (name == "fuel_nav") f(FuelNav{});
  else if (name == "min_snap") f(MinSnap{});
  else if (name == "zermelo_tv") f(ZermeloTv{});
  else return false;
  return true;
}

}  // namespace

int values_per_interval(int m) { return 1 + 2 * m + 3 * m * m; }

const pardel_model* device_model(const std::string& name) {
  const pardel_model* model = nullptr;
  visit_model(name, [&](auto m) { model = &decltype(m)::model(); });
  return model;
}

std::vector<double> evaluate_on_host(const std::string& model, int N, const std::vector<double>& q,
                                     const std::vector<double>& t, const std::vector<double>& p) {
  std::vector<double> out;
  visit_model(model, [&](auto m) { out = host_loop<decltype(m)>(N, q, t, p); });
  return out;
}

bool evaluate_on_device(const std::string& model, int N, const std::vector<double>& q, const std::vector<double>& t,
                        const std::vector<double>& p, std::vector<double>& out, std::string& why) {
  bool ran = false;
  if (!visit_model(model, [&](auto m) { ran = device_run<decltype(m)>(N, q, t, p, out, why); })) {
    why = "model " + model + " is not compiled for the device check";
    return false;
  }
  return ran;
}

}  // namespace pardel_cuda_check
