#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "common.hpp"
#include "crandall/diagnostics.hpp"
#include "crandall/filter.hpp"
#include "crandall/filtered.hpp"
#include "crandall/rng.hpp"

using bindings::to_array;
using bindings::without_gil;

namespace {

crandall::LinearFilter checked_filter(const std::vector<double>& a, const std::vector<double>& b,
                                      const std::vector<double>& c, const std::string& name) {
  const std::size_t n = b.size();
  if (n < 1 || n > static_cast<std::size_t>(crandall::kMaxFilter) || a.size() != n * n || c.size() != n)
    throw std::invalid_argument(name + ": b and c need n = 1 to 6 numbers, a n * n (row-major)");
  crandall::LinearFilter f;
  f.n = static_cast<int>(n);
  f.a = a;
  f.b = b;
  f.c = c;
  return f;
}

py::list filter_root_levels(const std::vector<double>& a, const std::vector<double>& b,
                            const std::vector<double>& c, double longest, int count) {
  const crandall::LinearFilter f = checked_filter(a, b, c, "filter_root_levels");
  const std::size_t m = b.size() + 2;
  py::list out;
  for (const crandall::RootLevel& level : crandall::root_levels(f, longest, count))
    out.append(py::make_tuple(level.length, to_array(level.phi, m, m), to_array(level.root, m, m)));
  return out;
}

}  // namespace

void register_diagnostics(py::module_& m) {
  m.attr("RANDOM_STREAM") = crandall::kRandomStream;
  // The depth below a fine step to which a filtered path's last rest is searched for touches
  // at the stop (filter.hpp, kGrazeDepth): part of a checkpoint's identity.
  m.attr("TOUCH_DEPTH") = crandall::kGrazeDepth;

  m.def(
      "filtered_trajectory",
      [](const crandall::Plan& plan, std::uint64_t path) {
        const crandall::Trajectory t =
            without_gil([&] { return crandall::filtered_trajectory(plan, path); });
        py::dict out;
        out["t"] = to_array(t.time, t.time.size(), 0);
        out["a_g"] = to_array(t.ground, t.ground.size(), 0);
        out["V"] = to_array(t.velocity, t.velocity.size(), 0);
        out["U"] = to_array(t.displacement, t.displacement.size(), 0);
        out["S"] = to_array(t.distance, t.distance.size(), 0);
        return out;
      },
      py::arg("plan"), py::arg("path"),
      "One path of a filtered plan's walked grid, point by point (skeleton points, event "
      "substeps, rest times), to the stop if observed: a dict of arrays t, a_g, V, U, S.");

  m.def(
      "filter_transition",
      [](const std::vector<double>& a, const std::vector<double>& b, const std::vector<double>& c,
         double h) {
        const crandall::LinearFilter f = checked_filter(a, b, c, "filter_transition");
        const std::size_t n = b.size();
        const auto t = crandall::transition(f, h);
        return py::make_tuple(to_array(t.phi, n + 2, n + 2), to_array(t.q, n + 2, n + 2));
      },
      py::arg("a"), py::arg("b"), py::arg("c"), py::arg("h"),
      "(Phi, Q) of the filter augmented with G = int a_g and D = int G over a step h: "
      "(n + 2) x (n + 2) arrays, state (z, G, D), unit noise intensity.");

  m.def("filter_root_levels", &filter_root_levels, py::arg("a"), py::arg("b"), py::arg("c"),
        py::arg("longest"), py::arg("count"),
        "The noise-space tree's levels as a filtered plan stores them: (length, Phi, R) for the "
        "lengths longest / 2^i, i < count, with R R^T = Q(length) (R lower triangular; the step's "
        "own R is the skeleton's root).");

  m.def(
      "exact_steps",
      [](const std::vector<double>& start, double step, double drift, double noise,
         std::uint64_t seed) {
        const std::vector<double> out =
            without_gil([&] { return crandall::exact_steps(start, step, drift, noise, seed); });
        return to_array(out, out.size(), 0);
      },
      py::arg("start"), py::arg("h"), py::arg("drift"), py::arg("noise"), py::arg("seed"),
      "One exact velocity step of length h from each start value (path i uses stream i).");

  m.def(
      "random_floor",
      [](std::uint64_t paths, std::uint64_t steps, std::uint64_t seed, int threads) {
        // Pure C++ on its own locals.
        return without_gil([&] { return crandall::random_floor(paths, steps, seed, threads); });
      },
      py::arg("paths"), py::arg("steps"), py::arg("seed"), py::arg("threads") = 0,
      "Generate the kernel's noise for paths x steps with no physics (a throughput floor).");

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
}
