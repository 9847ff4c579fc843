#include <chrono>
#include <cstdint>
#include <vector>

#include "common.hpp"
#include "crandall/levels.hpp"

namespace {

void def_run_samples(py::module_& m) {
  m.def(
      "run_samples",
      [](const crandall::Plan& plan, std::uint64_t first, std::uint64_t count, int threads,
         bool controls, py::object out, py::object controls_out,
         const std::vector<std::size_t>& control_slots) -> py::object {
        const crandall::Options& o = plan.options();
        const std::size_t slots = o.sample_slots();
        const auto grids = static_cast<std::size_t>(o.grids());
        const auto n = static_cast<std::size_t>(count);
        // The arrays written: the caller's (reused between calls), or new ones. Every element
        // is written, so neither is cleared first.
        auto buffer = [n](py::object given, std::vector<std::size_t> shape, const char* name) {
          if (given.is_none()) return py::array_t<double>(shape);
          auto a = py::cast<py::array>(given);
          std::vector<py::ssize_t> want(shape.begin(), shape.end());
          bool ok = a.dtype().is(py::dtype::of<double>()) && a.ndim() == static_cast<py::ssize_t>(shape.size()) &&
                    (a.flags() & py::array::c_style) && a.writeable();
          for (std::size_t i = 0; ok && i < shape.size(); ++i)
            ok = a.shape(static_cast<py::ssize_t>(i)) == want[i];
          if (!ok)
            throw std::invalid_argument(std::string(name) + " must be a writable C-contiguous "
                                        "float64 array of the samples' shape");
          return py::array_t<double>(a);
        };
        py::array_t<double> values = buffer(out, {n, slots, grids, std::size_t{3}}, "out");
        py::array_t<double> ctl;
        if (controls)
          ctl = buffer(controls_out,
                       {n, control_slots.empty() ? o.times.size() + (o.stop ? 1 : 0) : control_slots.size(),
                        static_cast<std::size_t>(crandall::control_count())},
                       "controls_out");
        double* values_ptr = values.mutable_data();
        double* ctl_ptr = controls ? ctl.mutable_data() : nullptr;
        const auto cancel = bindings::python_cancel_check();
        try {
          bindings::without_gil([&] {
            crandall::run_samples(plan, first, count, threads, values_ptr, ctl_ptr, cancel,
                                  control_slots);
            return 0;
          });
        } catch (const crandall::Cancelled&) {
          if (PyErr_Occurred()) throw py::error_already_set();
          throw std::runtime_error("run cancelled: the interpreter is exiting");
        }
        if (!controls) return std::move(values);
        return py::make_tuple(values, ctl);
      },
      py::arg("plan"), py::arg("first"), py::arg("count"), py::arg("threads") = 0,
      py::arg("controls") = false, py::arg("out") = py::none(), py::arg("controls_out") = py::none(),
      py::arg("control_slots") = std::vector<std::size_t>{},
      "Per-path values of paths first .. first + count - 1, shape (count, slots, grids, 3): "
      "at each output time (velocity, displacement, distance) on each coupled grid, and at the "
      "stop (time from the switch-off, displacement, distance), and with the plan's "
      "quadratic_variation one more slot (Q, 0, 0), Q = int_0^t0 noise^2 X^2 dt on that grid. The same bits for any thread "
      "count. With controls=True (exact method, an integral observed), returns (values, "
      "controls) with the base level's control sums, shape (count, slots, CONTROLS), or at the "
      "ascending slots control_slots only, shape (count, len(control_slots), CONTROLS). out and "
      "controls_out: arrays of exactly those shapes to write into (reused between calls).");
  m.attr("CONTROLS") = crandall::control_count();
  m.attr("WHITE_CONTROLS") = crandall::white_control_count();
}

void def_FeatureColumns(py::module_& m) {
  py::class_<crandall::FeatureColumns>(
      m, "FeatureColumns",
      "The feature columns of a run to an accuracy, one entry per column (levels.hpp): slot, "
      "variable, kind (0 value, 1 its square, 2 the Ito identity, 3 the identity at the stop, "
      "4 its magnitude, 5 constant times the value), "
      "power (1 or 2), constant, centre, inexact; with control sums, control (the control slot "
      "index) and beta (CONTROLS coefficients per column).")
      .def(py::init<>())
      .def_readwrite("slot", &crandall::FeatureColumns::slot)
      .def_readwrite("variable", &crandall::FeatureColumns::variable)
      .def_readwrite("kind", &crandall::FeatureColumns::kind)
      .def_readwrite("power", &crandall::FeatureColumns::power)
      .def_readwrite("constant", &crandall::FeatureColumns::constant)
      .def_readwrite("centre", &crandall::FeatureColumns::centre)
      .def_readwrite("inexact", &crandall::FeatureColumns::inexact)
      .def_readwrite("control", &crandall::FeatureColumns::control)
      .def_readwrite("beta", &crandall::FeatureColumns::beta);
}

void def_form_features(py::module_& m) {
  m.def(
      "form_features",
      [](py::array_t<double, py::array::c_style> samples, const crandall::FeatureColumns& columns,
         double two_drift, int level, py::array_t<double, py::array::c_style> out,
         py::object controls, int threads) {
        if (samples.ndim() != 4 || samples.shape(3) != 3)
          throw std::invalid_argument("form_features: samples must have run_samples' shape");
        const auto rows = static_cast<std::uint64_t>(samples.shape(0));
        if (out.ndim() != 2 || static_cast<std::uint64_t>(out.shape(0)) != rows ||
            static_cast<std::size_t>(out.shape(1)) != columns.slot.size() || !out.writeable())
          throw std::invalid_argument("form_features: out must be a writable (rows, columns) array");
        const double* ctl = nullptr;
        std::uint64_t control_slots = 0;
        py::array_t<double, py::array::c_style> c;
        if (!controls.is_none()) {
          c = py::cast<py::array_t<double, py::array::c_style>>(controls);
          if (c.ndim() != 3 || static_cast<std::uint64_t>(c.shape(0)) != rows ||
              c.shape(2) != crandall::control_count())
            throw std::invalid_argument("form_features: controls must have run_samples' shape");
          ctl = c.data();
          control_slots = static_cast<std::uint64_t>(c.shape(1));
        }
        const double* data = samples.data();
        double* dst = out.mutable_data();
        const auto slots = static_cast<std::uint64_t>(samples.shape(1));
        const int grids = static_cast<int>(samples.shape(2));
        bindings::without_gil([&] {
          crandall::form_features(data, rows, slots, grids, columns, two_drift, level, dst, ctl,
                                  control_slots, threads);
          return 0;
        });
        return out;
      },
      py::arg("samples"), py::arg("columns"), py::arg("two_drift"), py::arg("level"),
      py::arg("out"), py::arg("controls") = py::none(), py::arg("threads") = 0,
      "Into out (rows, columns): each column's value on the fine grid minus its centre, to its "
      "power; on level 0 minus its controls' multiples (when controls are given), on a finer "
      "level minus the coarse grid's (0 for columns exact in law). Returns out.");
}

void def_sum_products(py::module_& m) {
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

}  // namespace

void register_levels(py::module_& m) {
  def_run_samples(m);
  def_FeatureColumns(m);
  def_form_features(m);
  def_sum_products(m);
}
