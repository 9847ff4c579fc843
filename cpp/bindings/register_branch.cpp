#include <cstdint>
#include <string>

#include "common.hpp"
#include "crandall/branch.hpp"

void register_branch(py::module_& m) {
  m.def(
      "extend_paths",
      [](py::array states, py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> rows,
         py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> starts,
         py::array_t<std::uint64_t, py::array::c_style | py::array::forcecast> streams,
         py::array_t<double, py::array::c_style | py::array::forcecast> lengths,
         py::array_t<double, py::array::c_style | py::array::forcecast> noises,
         py::array_t<double, py::array::c_style | py::array::forcecast> drifts,
         std::uint64_t key, int threads, py::object touched, py::object slow,
         py::object slow_drifts) {
        if (!states.dtype().is(py::dtype::of<double>()) || states.ndim() != 3 ||
            states.shape(2) != 3 || !(states.flags() & py::array::c_style) || !states.writeable())
          throw std::invalid_argument("states must be a writable C-contiguous float64 array of "
                                      "shape (rows, steps + 1, 3)");
        const auto steps = static_cast<std::size_t>(lengths.size());
        if (noises.size() != lengths.size() || drifts.size() != lengths.size())
          throw std::invalid_argument("lengths, noises and drifts must have one value per step");
        if (states.shape(1) != static_cast<py::ssize_t>(steps + 1))
          throw std::invalid_argument("states must have steps + 1 = " + std::to_string(steps + 1) +
                                      " grid points per row");
        if (starts.size() != rows.size() || streams.size() != rows.size())
          throw std::invalid_argument("rows, starts and streams must have the same length");
        crandall::BranchGrid grid{lengths.data(), noises.data(), drifts.data(), steps};
        using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;
        Doubles slow_a, slow_d;
        if (slow.is_none() != slow_drifts.is_none())
          throw std::invalid_argument("slow and slow_drifts: give both or neither");
        if (!slow.is_none()) {
          slow_a = Doubles::ensure(slow);
          slow_d = Doubles::ensure(slow_drifts);
          if (!slow_a || !slow_d || slow_a.ndim() != 1 || slow_d.ndim() != 1 ||
              static_cast<std::size_t>(slow_a.size()) != steps ||
              static_cast<std::size_t>(slow_d.size()) != steps)
            throw std::invalid_argument("slow and slow_drifts must have one value per step");
          grid.slow = slow_a.data();
          grid.slow_drifts = slow_d.data();
        }
        double* data = static_cast<double*>(states.mutable_data());
        const auto rows_total = static_cast<std::size_t>(states.shape(0));
        const auto count = static_cast<std::size_t>(rows.size());
        std::uint8_t* flags = nullptr;
        if (!touched.is_none()) {
          const char* wrong = "touched must be None or a writable C-contiguous uint8 array of "
                              "shape (rows, steps)";
          if (!py::isinstance<py::array>(touched)) throw std::invalid_argument(wrong);
          auto t = py::reinterpret_borrow<py::array>(touched);
          if (!t.dtype().is(py::dtype::of<std::uint8_t>()) || t.ndim() != 2 || t.shape(0) != static_cast<py::ssize_t>(rows_total) ||
              t.shape(1) != static_cast<py::ssize_t>(steps) || !(t.flags() & py::array::c_style) ||
              !t.writeable())
            throw std::invalid_argument(wrong);
          flags = static_cast<std::uint8_t*>(t.mutable_data());
        }
        bindings::without_gil([&] {
          crandall::extend_paths(data, rows_total, grid, rows.data(), starts.data(), streams.data(),
                                 count, key, threads, flags);
          return 0;
        });
      },
      py::arg("states"), py::arg("rows"), py::arg("starts"), py::arg("streams"),
      py::arg("lengths"), py::arg("noises"), py::arg("drifts"), py::arg("key"),
      py::arg("threads") = 0, py::arg("touched") = py::none(), py::arg("slow") = py::none(),
      py::arg("slow_drifts") = py::none(),
      "Continues rows `rows` of `states` (rows x (steps + 1) x 3: velocity, displacement, "
      "distance at every grid point) from grid point starts[i] to the end of the grid with the "
      "noise of stream streams[i] of `key`; step k has length lengths[k], noise noises[k] and "
      "drift drifts[k]. In place; the GIL is released. touched (optional uint8, rows x steps) "
      "receives whether each step a row takes touched 0 (1) or not (0; a coast step: 0). "
      "slow, slow_drifts (optional, one per step): a step that starts with |x| < slow[k] "
      "takes the drift slow_drifts[k] instead of drifts[k].");
}
