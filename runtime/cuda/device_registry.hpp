/**
 * @file device_registry.hpp
 * Between the host side of solve_batch_cuda (cuda.cu) and the device code of each model compiled
 * for the device (one generated source per model, runtime/cuda/CMakeLists.txt): the batch as flat
 * arrays, what comes back, and the registry of (model, discretization) -> launch loop.
 */
#ifndef PARDEL_CUDA_DEVICE_REGISTRY_HPP
#define PARDEL_CUDA_DEVICE_REGISTRY_HPP

#include <functional>
#include <string>
#include <vector>

#include "batch_sweep.hpp"
#include "pardel/kernel_abi.h"

namespace pardel::cuda_detail {

/** A batch as the device takes it: B problems of N intervals on one grid. */
struct DeviceBatch {
  int B = 0, N = 0, np = 0;
  const double* q = nullptr;    ///< B (N+1) dim values: the guesses, boundary values at the ends
  const double* t = nullptr;    ///< N+1 node times
  const double* h = nullptr;    ///< N steps
  const double* p = nullptr;    ///< B np params
  const int* invalid = nullptr; ///< B flags: 1 for a problem left out
  batch_sweep::Settings settings;
  int check_every = 32;
  int blocks_per_problem = 0;  ///< CudaSettings::blocks_per_problem
  std::function<bool()> keep_going;
};

/** One problem's record, read back from the device. */
struct ProblemRecord {
  int status = batch_sweep::not_started;
  long iterations = 0;
  int node = -1, unresolved = -1;
  int reason = 0;  ///< Newton: a batch_newton::Reason (why it stalled or is non-finite)
  double residual = 0, scale = 0, target = 0, r_initial = 0;
  std::vector<double> comp_residual, comp_target;
};

struct DeviceBatchResult {
  double* q = nullptr;  ///< B (N+1) dim values, written: each problem's returned iterate
  std::vector<ProblemRecord> records;
  double upload = 0, sweeps = 0, download = 0;
  long sweeps_run = 0;  ///< sweeps launched; Newton: iterations of the problem that ran longest
};

/** Runs a batch of one model and discretization; returns "" or what failed on the device. */
using DeviceRunner = std::string (*)(const DeviceBatch&, DeviceBatchResult&);

struct DeviceEntry {
  const pardel_model* model;
  const pardel_discretization* discretization;
  DeviceRunner run;         ///< the Jacobi and Jacobi-Newton sweeps
  DeviceRunner run_newton;  ///< Newton, one thread per problem
};

/** Every (model, discretization) of the device build (filled by the generated registration): the
 *  bundled models of PARDEL_DEVICE_MODELS, then those registered with DeviceRegistration. */
const std::vector<DeviceEntry>& device_entries();

/** A static object of this type in a model's device source (pardel_add_model(... DEVICE),
 *  cmake/PardelDeviceModel.cmake) adds the model's entries with `add` when the program starts. */
struct DeviceRegistration {
  explicit DeviceRegistration(void (*add)(std::vector<DeviceEntry>&));
};

/** Adds the discretization of `model` whose sweep kernel is `sweep` (a host address). */
void add_entry(std::vector<DeviceEntry>& entries, const pardel_model& model, pardel_sweep_kernel sweep,
               DeviceRunner run, DeviceRunner run_newton);

}  // namespace pardel::cuda_detail

#endif  // PARDEL_CUDA_DEVICE_REGISTRY_HPP
