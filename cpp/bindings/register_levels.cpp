#include <chrono>
#include <cstdint>
#include <vector>

#include "common.hpp"
#include "crandall/levels.hpp"

void register_levels(py::module_& m) {
  m.def(
      "run_samples",
      [](const crandall::Plan& plan, std::uint64_t first, std::uint64_t count, int threads,
         bool controls) -> py::object {
        using clock = std::chrono::steady_clock;
        const bool main = bindings::on_main_thread();
        auto last = clock::now();
        // As run_chunk: the calling thread checks for Ctrl-C (main thread) or the exit.
        auto cancel = [&last, main]() {
          if (!main) return bindings::g_exiting.load();
          const auto now = clock::now();
          if (now - last < std::chrono::milliseconds(50)) return false;
          last = now;
          py::gil_scoped_acquire gil;
          return PyErr_CheckSignals() != 0;
        };
        std::vector<double> out, ctl;
        try {
          out = bindings::without_gil([&] {
            return crandall::run_samples(plan, first, count, threads, cancel,
                                         controls ? &ctl : nullptr);
          });
        } catch (const crandall::Cancelled&) {
          if (PyErr_Occurred()) throw py::error_already_set();
          throw std::runtime_error("run cancelled: the interpreter is exiting");
        }
        const crandall::Options& o = plan.options();
        const std::size_t slots = o.times.size() + (o.stop ? 1 : 0);
        const auto grids = static_cast<std::size_t>(o.grids());
        py::array_t<double> a({static_cast<std::size_t>(count), slots, grids, std::size_t{3}});
        std::memcpy(a.mutable_data(), out.data(), out.size() * sizeof(double));
        if (!controls) return std::move(a);
        py::array_t<double> c({static_cast<std::size_t>(count), slots,
                               static_cast<std::size_t>(crandall::control_count())});
        std::memcpy(c.mutable_data(), ctl.data(), ctl.size() * sizeof(double));
        return py::make_tuple(a, c);
      },
      py::arg("plan"), py::arg("first"), py::arg("count"), py::arg("threads") = 0,
      py::arg("controls") = false,
      "Per-path values of paths first .. first + count - 1, shape (count, slots, grids, 3): "
      "at each output time (velocity, displacement, distance) on each coupled grid, and at the "
      "stop (time from the switch-off, displacement, distance). The same bits for any thread "
      "count. With controls=True (exact method, an integral observed), returns (values, "
      "controls) with the base level's control sums, shape (count, slots, CONTROLS).");
  m.attr("CONTROLS") = crandall::control_count();

  m.def(
      "sum_products",
      [](py::array_t<double, py::array::c_style | py::array::forcecast> values,
         const std::vector<int>& widths, int threads) {
        if (values.ndim() != 2) throw std::invalid_argument("sum_products: values must be 2-D");
        const auto rows = static_cast<std::uint64_t>(values.shape(0));
        const auto cols = static_cast<std::uint64_t>(values.shape(1));
        const double* data = values.data();
        std::vector<double> out = bindings::without_gil(
            [&] { return crandall::sum_products(data, rows, cols, widths, threads); });
        py::array_t<double> a(out.size());
        std::memcpy(a.mutable_data(), out.data(), out.size() * sizeof(double));
        return a;
      },
      py::arg("values"), py::arg("widths"), py::arg("threads") = 0,
      "Per group of consecutive columns (widths 1 to 32): the column sums and the upper "
      "triangle of F_g^T F_g, summed in a fixed order (the same bits for any thread count).");
}
