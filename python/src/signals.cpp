/**
 * @file signals.cpp
 * Work that runs with the GIL released on a worker thread while the calling thread watches for
 * Ctrl-C (batches and sweeps).
 */
#include "bindings.hpp"

#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>

namespace pardel::python {

/**
 * Runs `work` on a worker thread with the GIL released while this thread checks Python's signals
 * every 50 ms; a pending exception (KeyboardInterrupt) sets `stop`, and is returned once the work
 * has ended (nullptr when none). An exception of the work is rethrown here.
 */
std::unique_ptr<py::error_already_set> watching_signals(const std::function<void()>& work, std::atomic<bool>& stop) {
  std::exception_ptr failure;
  std::unique_ptr<py::error_already_set> pending;
  {
    py::gil_scoped_release release;
    std::mutex mutex;
    std::condition_variable finished;
    bool done = false;
    std::thread worker([&] {
      try {
        work();
      } catch (...) {
        failure = std::current_exception();
      }
      {
        const std::lock_guard<std::mutex> lock(mutex);
        done = true;
      }
      finished.notify_one();
    });
    std::unique_lock<std::mutex> lock(mutex);
    while (!finished.wait_for(lock, kSignalCheckPeriod, [&done] { return done; })) {
      if (pending) continue;
      lock.unlock();
      {
        py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) {
          pending = std::make_unique<py::error_already_set>();
          stop.store(true);
        }
      }
      lock.lock();
    }
    lock.unlock();
    worker.join();
  }
  if (failure) std::rethrow_exception(failure);
  return pending;
}

}  // namespace pardel::python
