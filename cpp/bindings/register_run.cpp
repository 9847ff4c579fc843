#include <atomic>
#include <chrono>
#include <cstring>
#include <exception>
#include <new>
#include <optional>
#include <string>
#include <thread>

#include "common.hpp"
#include "crandall/accumulators.hpp"
#include "crandall/dispatch.hpp"
#include "crandall/rng.hpp"
#include "crandall/plan.hpp"
#include "crandall/run.hpp"

namespace {

using crandall::Moments;

// Set by an atexit hook: the interpreter is shutting down. Non-daemon threads have been joined
// by then; a daemon thread still in a run must neither call into Python nor take the GIL
// again (during finalization that ends the thread by unwinding its stack, which aborts the
// process when it meets an OpenMP region or a destructor).
std::atomic<bool> g_exiting{false};

// Whether the calling thread is Python's main thread (asked each time: a forked child's main
// thread is the one that forked). Needs the GIL.
bool on_main_thread() {
  try {
    const auto main = py::module_::import("threading").attr("main_thread")().attr("ident");
    return PyThread_get_thread_ident() == main.cast<unsigned long>();
  } catch (const py::error_already_set&) {
    return false;
  }
}

// f() with the GIL released. Exceptions are carried across the GIL's return by hand, not by a
// scoped guard, so that nothing is destroyed in between. A daemon thread that finishes (or
// abandons) its work while the interpreter exits parks for good instead of taking the GIL back,
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

py::array_t<double> to_array(const std::vector<double>& v, std::size_t rows, std::size_t cols) {
  py::array_t<double> out(cols == 0 ? std::vector<py::ssize_t>{static_cast<py::ssize_t>(rows)}
                                    : std::vector<py::ssize_t>{static_cast<py::ssize_t>(rows),
                                                               static_cast<py::ssize_t>(cols)});
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(double));
  return out;
}

std::vector<double> from_array(const py::array_t<double, py::array::c_style | py::array::forcecast>& a,
                               std::size_t expected, const char* name) {
  if (static_cast<std::size_t>(a.size()) != expected)
    throw std::invalid_argument(std::string(name) + " has the wrong size for these slots");
  return std::vector<double>(a.data(), a.data() + a.size());
}

Moments moments_from(std::size_t slots, const py::array_t<double, py::array::c_style | py::array::forcecast>& counts,
                     const py::array_t<double, py::array::c_style | py::array::forcecast>& means,
                     const py::array_t<double, py::array::c_style | py::array::forcecast>& central) {
  Moments m(slots);
  m.counts() = from_array(counts, slots, "counts");
  m.means() = from_array(means, slots * crandall::kVariables, "means");
  m.central() = from_array(central, slots * crandall::kMonomials, "central");
  return m;
}

}  // namespace

void register_run(py::module_& m) {
  py::module_::import("atexit").attr("register")(
      py::cpp_function([]() { g_exiting.store(true); }));
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
  m.attr("CHUNK_PATHS") = crandall::kChunkPaths;
  m.attr("BLOCK_PATHS") = crandall::kBlockPaths;
  m.attr("LANES") = crandall::kLanes;
  m.def("monomial_exponents", [] {
    py::list out;
    for (const auto& e : crandall::monomial_exponents()) out.append(py::make_tuple(e[0], e[1], e[2]));
    return out;
  }, "Exponent triples (a, b, c) of the central sums, in storage order.");

  py::class_<crandall::Options>(m, "Options", "Options of a run (validated by Plan).")
      .def(py::init<>())
      .def_readwrite("drift", &crandall::Options::drift)
      .def_readwrite("noise", &crandall::Options::noise)
      .def_readwrite("switch_off", &crandall::Options::switch_off)
      .def_readwrite("times", &crandall::Options::times)
      .def_readwrite("dt", &crandall::Options::dt)
      .def_readwrite("min_steps", &crandall::Options::min_steps)
      .def_property(
          "method",
          [](const crandall::Options& o) { return std::string(crandall::method_name(o.method)); },
          [](crandall::Options& o, const std::string& name) { o.method = crandall::parse_method(name); })
      .def_readwrite("velocity", &crandall::Options::velocity)
      .def_readwrite("displacement", &crandall::Options::displacement)
      .def_readwrite("distance", &crandall::Options::distance)
      .def_readwrite("stop", &crandall::Options::stop)
      .def_readwrite("seed", &crandall::Options::seed)
      .def_readwrite("paths", &crandall::Options::paths)
      .def("validate", &crandall::Options::validate);

  py::class_<crandall::Plan>(m, "Plan", "A validated run: the time grid and the path partition.")
      .def(py::init<crandall::Options>(), py::arg("options"))
      .def_property_readonly("steps_per_path", &crandall::Plan::steps_per_path)
      .def_property_readonly("chunks", &crandall::Plan::chunks)
      .def("chunk_paths", &crandall::Plan::chunk_paths, py::arg("chunk"))
      .def_property_readonly("options", &crandall::Plan::options);

  py::class_<Moments>(m, "Moments",
                      "Count, means and central sums up to order 4 of three variables per slot.")
      .def(py::init<std::size_t>(), py::arg("slots"))
      .def(py::init(&moments_from), py::arg("slots"), py::arg("counts"), py::arg("means"),
           py::arg("central"))
      .def_property_readonly("slots", &Moments::slots)
      .def_property_readonly("counts", [](const Moments& a) { return to_array(a.counts(), a.slots(), 0); })
      .def_property_readonly("means", [](const Moments& a) {
        return to_array(a.means(), a.slots(), crandall::kVariables);
      })
      .def_property_readonly("central", [](const Moments& a) {
        return to_array(a.central(), a.slots(), crandall::kMonomials);
      })
      .def("raw", [](const Moments& a) {
        std::vector<double> out(a.slots() * crandall::kMonomials, 0.0);
        for (std::size_t s = 0; s < a.slots(); ++s) {
          if (a.counts()[s] <= 0.0) continue;
          // Centre the sums on zero (delta = mean), then divide by the count.
          crandall::recentre(&a.central()[s * crandall::kMonomials], &a.means()[s * crandall::kVariables],
                             &out[s * crandall::kMonomials]);
          for (int k = 0; k < crandall::kMonomials; ++k) out[s * crandall::kMonomials + k] /= a.counts()[s];
        }
        return to_array(out, a.slots(), crandall::kMonomials);
      }, "Raw moments E[x^a y^b z^c] per slot, in the order of monomial_exponents().")
      .def("merge", &Moments::merge, py::arg("other"),
           "Merge another accumulator into this one (order matters only through rounding).")
      .def(py::pickle(
          [](const Moments& a) {
            return py::make_tuple(a.slots(), to_array(a.counts(), a.slots(), 0),
                                  to_array(a.means(), a.slots(), crandall::kVariables),
                                  to_array(a.central(), a.slots(), crandall::kMonomials));
          },
          [](const py::tuple& t) {
            return moments_from(t[0].cast<std::size_t>(), t[1].cast<py::array_t<double>>(),
                                t[2].cast<py::array_t<double>>(), t[3].cast<py::array_t<double>>());
          }));

  py::class_<crandall::ChunkResult>(m, "ChunkResult")
      .def_readonly("times", &crandall::ChunkResult::times)
      .def_readonly("stop", &crandall::ChunkResult::stop);

  m.def(
      "run_chunk",
      [](const crandall::Plan& plan, std::uint64_t chunk, int threads) {
        using clock = std::chrono::steady_clock;
        const bool main = on_main_thread();
        auto last = clock::now();
        // Called by the run's calling thread only. Python runs signal handlers on the main
        // thread alone, so elsewhere there is nothing to check but the interpreter's exit.
        auto interrupted = [&last, main]() {
          if (!main) return g_exiting.load();
          const auto now = clock::now();
          if (now - last < std::chrono::milliseconds(50)) return false;
          last = now;
          py::gil_scoped_acquire gil;
          return PyErr_CheckSignals() != 0;
        };
        try {
          // Pure C++ on data owned by the plan and the result: safe without the GIL, and other
          // Python threads (a progress bar) keep running.
          return without_gil([&] { return crandall::run_chunk(plan, chunk, threads, interrupted); });
        } catch (const crandall::Interrupted&) {
          // The KeyboardInterrupt (or a signal handler's exception) set by PyErr_CheckSignals.
          if (PyErr_Occurred()) throw py::error_already_set();
          throw std::runtime_error("run abandoned: the interpreter is exiting");
        }
      },
      py::arg("plan"), py::arg("chunk"), py::arg("threads") = 0,
      "Simulate one chunk of paths; bitwise the same for any thread count.");

  m.def(
      "random_floor",
      [](std::uint64_t paths, std::uint64_t steps, std::uint64_t seed, int threads) {
        // Pure C++ on its own locals.
        return without_gil([&] { return crandall::random_floor(paths, steps, seed, threads); });
      },
      py::arg("paths"), py::arg("steps"), py::arg("seed"), py::arg("threads") = 0,
      "Generate the kernel's noise for paths x steps with no physics (a throughput floor).");

  // The kernel variant: CRANDALL_ISA or the best the CPU supports, chosen here so that a bad
  // CRANDALL_ISA fails the import with its message rather than the first simulation.
  try {
    crandall::active_kernel();
  } catch (const std::invalid_argument& e) {
    throw py::import_error(e.what());
  }
  m.attr("RANDOM_STREAM") = crandall::kRandomStream;

  m.def(
      "build_info",
      [] {
        const crandall::BuildInfo b = crandall::build_info();
        py::dict d;
        d["isa"] = b.isa;
        d["isa_compiled"] = b.isa_compiled;
        d["isa_available"] = b.isa_available;
        d["philox_paths_per_register"] = b.philox_paths_per_register;
        d["doubles_per_register"] = b.doubles_per_register;
        d["random_stream"] = b.random_stream;
        d["compiler"] = b.compiler;
        return d;
      },
      "What runs: the kernel variant in use (isa: CRANDALL_ISA or the best the CPU supports), "
      "the variants compiled in and those supported here, Philox paths and doubles per "
      "register, the random-stream version, the compiler. Every variant gives the same numbers.");

  m.def(
      "draw_noise",
      [](std::uint64_t seed, std::uint64_t path0, std::uint64_t count, std::uint64_t pair) {
        std::vector<double> out;
        {
          py::gil_scoped_release release;
          out = crandall::draw_noise(seed, path0, count, pair);
        }
        return to_array(out, 6, static_cast<std::size_t>(count));
      },
      py::arg("seed"), py::arg("path0"), py::arg("count"), py::arg("pair"),
      "Diagnostics: the kernel's draws of step pair `pair` for paths path0 .. path0 + count - 1, "
      "shape (6, count): normals of steps 2 pair and 2 pair + 1, their exponentials, their coins.");

  m.def(
      "simulate_states",
      [](const crandall::Plan& plan) {
        std::vector<double> out;
        {
          py::gil_scoped_release release;
          out = crandall::simulate_states(plan);
        }
        return to_array(out, out.size(), 0);
      },
      py::arg("plan"),
      "Diagnostics: every path's velocity at the end of the plan's last segment, velocity only, "
      "exact or Euler method, one thread, through the kernel in use.");

  m.def(
      "exact_steps",
      [](const std::vector<double>& start, double h, double drift, double noise, std::uint64_t seed) {
        const std::vector<double> out =
            without_gil([&] { return crandall::exact_steps(start, h, drift, noise, seed); });
        return to_array(out, out.size(), 0);
      },
      py::arg("start"), py::arg("h"), py::arg("drift"), py::arg("noise"), py::arg("seed"),
      "One exact velocity step of length h from each start value (path i uses stream i).");
}
