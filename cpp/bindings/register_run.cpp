#include <chrono>
#include <cstdint>
#include <cstring>
#include <exception>
#include <new>
#include <stdexcept>

#include "common.hpp"
#include "crandall/plan.hpp"
#include "crandall/run.hpp"

void register_run(py::module_& m) {
  py::module_::import("atexit").attr("register")(
      py::cpp_function([]() { bindings::g_exiting.store(true); }));
  // Memory runs out in the accumulators (they grow with the output times, the observables and
  // the threads); say so rather than pybind11's bare "std::bad_alloc".
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const std::bad_alloc&) {
      PyErr_SetString(PyExc_MemoryError,
                      "crandall: out of memory allocating a run's accumulators (their size grows "
                      "with the number of output times and with the threads); use fewer output "
                      "times or threads, or more memory");
    }
  });

  py::class_<crandall::ChunkResult>(m, "ChunkResult")
      .def_readonly("times", &crandall::ChunkResult::times)
      .def_readonly("stop", &crandall::ChunkResult::stop)
      .def_readonly("peaks", &crandall::ChunkResult::peaks)
      .def_readonly("peaks_stop", &crandall::ChunkResult::peaks_stop)
      .def_readonly("energy", &crandall::ChunkResult::energy)
      .def_property_readonly(
          "histogram_counts",
          [](const crandall::ChunkResult& r) {
            // One uint64 array per axis of Options.histogram_axes (empty if not recorded).
            py::list out;
            for (const auto& c : r.histogram_counts) {
              py::array_t<std::uint64_t> a(static_cast<py::ssize_t>(c.size()));
              if (!c.empty()) std::memcpy(a.mutable_data(), c.data(), c.size() * sizeof(std::uint64_t));
              out.append(a);
            }
            return out;
          });

  m.def(
      "run_chunk",
      [](const crandall::Plan& plan, std::uint64_t chunk, int threads) {
        const auto cancel = bindings::python_cancel_check();
        try {
          // Pure C++ on data owned by the plan and the result: safe without the GIL, and other
          // Python threads (a progress bar) keep running.
          return bindings::without_gil(
              [&] { return crandall::run_chunk(plan, chunk, threads, cancel); });
        } catch (const crandall::Cancelled&) {
          // The KeyboardInterrupt (or a signal handler's exception) set by PyErr_CheckSignals.
          if (PyErr_Occurred()) throw py::error_already_set();
          throw std::runtime_error("run cancelled: the interpreter is exiting");
        }
      },
      py::arg("plan"), py::arg("chunk"), py::arg("threads") = 0,
      "Simulate one chunk of paths; bitwise the same for any thread count.");

  m.def("set_thread_work", &crandall::set_thread_work, py::arg("steps"),
        "Set the least work (path steps) a thread of a parallel loop gets, for the process; "
        "returns the previous value. The tests set 1 (their runs are small).");
}
