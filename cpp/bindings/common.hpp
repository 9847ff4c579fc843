// What every binding file shares: the one pybind11 include (one place for the includes avoids
// ODR trouble), the register_* functions module.cpp calls, and the helpers to run C++ without
// the GIL and to hand arrays to NumPy.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/operators.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstring>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

namespace py = pybind11;

// One per area, each in register_<area>.cpp.
void register_plan(py::module_& m);         // Options, Plan, the partition constants
void register_moments(py::module_& m);      // Moments, monomial_exponents
void register_histogram(py::module_& m);    // BinEdges
void register_run(py::module_& m);          // run_chunk, ChunkResult, cancelling a run
void register_diagnostics(py::module_& m);  // exact_steps, random_floor, build_info, ...
void register_levels(py::module_& m);       // run_samples, sum_products (adaptive runs)
void register_branch(py::module_& m);       // extend_paths (rare-event estimators)
void register_newmark(py::module_& m);      // newmark_exact, newmark_slammer, newmark_sweep
void register_detfunc(py::module_& m);      // det_exp, det_log, det_log1p, det_log_erfc

namespace bindings {

// Set by an atexit hook (register_run): the interpreter is shutting down. Non-daemon threads
// have been joined by then; a daemon thread still in a run must neither call into Python nor
// take the GIL again (during finalization that ends the thread by unwinding its stack, which
// aborts the process when it meets an OpenMP region or a destructor).
inline std::atomic<bool> g_exiting{false};

// Whether the calling thread is Python's main thread (asked each time: a forked child's main
// thread is the one that forked). Needs the GIL.
inline bool on_main_thread() {
  try {
    const auto main = py::module_::import("threading").attr("main_thread")().attr("ident");
    return PyThread_get_thread_ident() == main.cast<unsigned long>();
  } catch (const py::error_already_set&) {
    return false;
  }
}

// f() with the GIL released. Exceptions are carried across the GIL's return by hand, not by a
// scoped guard, so that nothing is destroyed in between. A daemon thread that finishes (or
// cancels) its work while the interpreter exits parks for good instead of taking the GIL back,
// as CPython itself does for daemon threads since 3.14; the process exit ends it.
template <class F>
auto without_gil(F&& f) -> decltype(f()) {
  const bool main = on_main_thread();
  std::optional<decltype(f())> out;
  std::exception_ptr error;
  PyThreadState* state = PyEval_SaveThread();
  try {
    out.emplace(f());
  } catch (...) {
    error = std::current_exception();
  }
  if (g_exiting.load() && !main)
    for (;;) std::this_thread::sleep_for(std::chrono::hours(1));
  PyEval_RestoreThread(state);
  if (error) std::rethrow_exception(error);
  return std::move(*out);
}

// A copy of v as a NumPy array of shape (rows,) when cols == 0, else (rows, cols).
inline py::array_t<double> to_array(const std::vector<double>& v, std::size_t rows,
                                    std::size_t cols) {
  py::array_t<double> out(cols == 0 ? std::vector<py::ssize_t>{static_cast<py::ssize_t>(rows)}
                                    : std::vector<py::ssize_t>{static_cast<py::ssize_t>(rows),
                                                               static_cast<py::ssize_t>(cols)});
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(double));
  return out;
}

// The cancel check of a run driven from Python (run.hpp's CancelCheck), called by the run's
// calling thread only. Python runs signal handlers on the main thread alone, so elsewhere there
// is nothing to check but the interpreter's exit; on the main thread, at most every 50 ms, a
// signal (Ctrl-C) cancels the run and its exception (KeyboardInterrupt) propagates. Needs the
// GIL when made.
inline std::function<bool()> python_cancel_check() {
  using clock = std::chrono::steady_clock;
  const bool main = on_main_thread();
  auto last = std::make_shared<clock::time_point>(clock::now());
  return [last, main]() {
    if (!main) return g_exiting.load();
    const auto now = clock::now();
    if (now - *last < std::chrono::milliseconds(50)) return false;
    *last = now;
    py::gil_scoped_acquire gil;
    return PyErr_CheckSignals() != 0;
  };
}

}  // namespace bindings
