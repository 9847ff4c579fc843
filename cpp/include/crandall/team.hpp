// The thread team shared by every run of the core (run_chunk, run_samples): blocks of paths
// claimed in order from a shared counter, every exception carried back to the calling thread,
// and a cancel request polled by the calling thread only (Python handles signals on its main
// thread) between blocks, every kPollSteps steps inside its own blocks (Workspace::cancelled),
// and every 10 ms while it waits for the other threads' blocks. The other threads read the
// flag it sets, so every thread quits within kPollSteps steps of a request.
#pragma once

#include <omp.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>

#include "crandall/kernel.hpp"
#include "crandall/run.hpp"

namespace crandall {

// Runs body(ws, b) for every block b in [0, blocks) on `team` threads. setup() makes a thread's
// Workspace (its `cancelled` is set here); body returns false to stop the thread (a cancel seen
// after the block's paths, which must then not be kept); finish(ws) runs on every thread whose
// workspace was made, after its last block, unless the run was cancelled or failed. Throws
// Cancelled if the run was cancelled, or the first exception any thread raised.
template <class Setup, class Body, class Finish>
void run_team(int team, long blocks, const CancelCheck& cancel, Setup setup, Body body,
              Finish finish) {
  std::atomic<bool> cancelled{false};
  std::atomic<long> next_claim{0}, finished{0};
  std::exception_ptr error;
  std::mutex error_mutex, done_mutex;
  std::condition_variable done;  // signalled when the last block finishes or the run fails
  if (cancel && cancel()) throw Cancelled();  // a request already pending

  // No exception may leave an OpenMP region (that terminates the process): every one is
  // caught here, the run is cancelled, and the first is rethrown on the calling thread.
  auto fail = [&](std::exception_ptr e) noexcept {
    {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = e;
    }
    cancelled.store(true);
    std::lock_guard<std::mutex> lock(done_mutex);
    done.notify_all();
  };
  auto poll = [&]() noexcept {
    if (cancel && !cancelled.load()) {
      try {
        if (cancel()) cancelled.store(true);
      } catch (...) {
        fail(std::current_exception());
      }
    }
    return cancelled.load();
  };

#pragma omp parallel num_threads(team)
  {
    const bool caller = omp_get_thread_num() == 0;
    std::unique_ptr<Workspace> ws;
    try {
      ws = setup();
      if (caller)
        ws->cancelled = poll;
      else
        ws->cancelled = [&cancelled]() { return cancelled.load(std::memory_order_relaxed); };
    } catch (...) {
      fail(std::current_exception());
    }
    while (ws && !ws->cancelled()) {
      const long b = next_claim.fetch_add(1);
      if (b >= blocks) break;
      try {
        ws->reset();
        if (!body(*ws, b)) break;
      } catch (...) {
        fail(std::current_exception());
        break;
      }
      if (finished.fetch_add(1) + 1 == blocks) {
        std::lock_guard<std::mutex> lock(done_mutex);
        done.notify_all();
      }
    }
    if (caller) {
      // The other threads may still be running blocks (a single long block, or more threads
      // than cores with this one descheduled): keep checking for a cancel request until they
      // are done instead of waiting for them at the end of the region.
      while (!poll()) {
        std::unique_lock<std::mutex> lock(done_mutex);  // not held while polling: fail() takes it
        if (finished.load() >= blocks || cancelled.load()) break;
        done.wait_for(lock, std::chrono::milliseconds(10));
      }
    }
    if (ws && !cancelled.load()) {
      try {
        finish(*ws);
      } catch (...) {
        fail(std::current_exception());
      }
    }
  }
  if (error) std::rethrow_exception(error);
  if (cancelled.load()) throw Cancelled();
}

}  // namespace crandall
