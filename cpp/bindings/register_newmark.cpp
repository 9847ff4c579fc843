#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "common.hpp"
#include "crandall/newmark.hpp"

namespace {

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;
namespace nm = crandall::newmark;

// One case with its histories: (summary, velocity, displacement, events), events an array of
// rows (onset, stop, direction, stopped).
py::tuple with_history(const Doubles& a, double dt, double sign, bool slammer, const nm::Yield& y,
                       double ky) {
  if (a.ndim() != 1) throw std::invalid_argument("acceleration: must be one-dimensional");
  const auto n = static_cast<std::size_t>(a.size());
  Doubles velocity(static_cast<py::ssize_t>(n)), displacement(static_cast<py::ssize_t>(n));
  std::vector<nm::Event> events;
  nm::History h{velocity.mutable_data(), displacement.mutable_data(), &events};
  const double* data = a.data();
  const nm::Summary s = bindings::without_gil([&] {
    return slammer ? nm::slammer(data, n, dt, sign, ky, h) : nm::exact(data, n, dt, sign, y, h);
  });
  py::array_t<double> ev(std::vector<py::ssize_t>{static_cast<py::ssize_t>(events.size()), 4});
  auto e = ev.mutable_unchecked<2>();
  for (std::size_t k = 0; k < events.size(); ++k) {
    const auto row = static_cast<py::ssize_t>(k);
    e(row, 0) = events[k].onset;
    e(row, 1) = events[k].stop;
    e(row, 2) = events[k].direction;
    e(row, 3) = events[k].stopped ? 1.0 : 0.0;
  }
  py::tuple summary = py::make_tuple(s.displacement, s.max_displacement, s.min_displacement,
                                     s.slips);
  return py::make_tuple(summary, velocity, displacement, ev);
}

}  // namespace

void register_newmark(py::module_& m) {
  m.attr("STANDARD_GRAVITY") = nm::kStandardGravity;
  m.def(
      "newmark_exact",
      [](const Doubles& a, double dt, double sign, double kd, double ku, double sd, double su) {
        return with_history(a, dt, sign, false, nm::Yield{kd, ku, sd, su}, 0.0);
      },
      py::arg("acceleration"), py::arg("dt"), py::arg("sign"), py::arg("kd"), py::arg("ku"),
      py::arg("sd"), py::arg("su"),
      "The exact block on one record (m/s^2; yields in m/s^2, ku = su = inf for one-way): "
      "((displacement, max, min, slips), velocity, displacement, events), the histories at "
      "the samples in W's sense (positive downslope), events rows (onset, stop, direction, "
      "stopped).");
  m.def(
      "newmark_slammer",
      [](const Doubles& a, double dt, double sign, double ky) {
        return with_history(a, dt, sign, true, nm::Yield{}, ky);
      },
      py::arg("acceleration"), py::arg("dt"), py::arg("sign"), py::arg("ky"),
      "pySLAMMER 0.2.2's rigid block on one record (m/s^2), ky in g; as newmark_exact.");
  m.def(
      "newmark_sweep",
      [](const std::vector<Doubles>& records, const std::vector<double>& dts,
         const Doubles& yields, const std::vector<double>& signs, const std::string& method,
         int threads) {
        if (records.size() != dts.size())
          throw std::invalid_argument("records and dts must have the same length");
        if (yields.ndim() != 2 || yields.shape(1) != 4)
          throw std::invalid_argument("yields must have shape (cases, 4)");
        nm::Method which;
        if (method == "exact")
          which = nm::Method::kExact;
        else if (method == "slammer")
          which = nm::Method::kSlammer;
        else
          throw std::invalid_argument("method must be 'exact' or 'slammer', got '" + method + "'");
        std::vector<nm::RecordView> views;
        for (std::size_t r = 0; r < records.size(); ++r) {
          if (records[r].ndim() != 1)
            throw std::invalid_argument("records must be one-dimensional");
          views.push_back({records[r].data(), static_cast<std::size_t>(records[r].size()), dts[r]});
        }
        std::vector<nm::Yield> ys;
        auto y = yields.unchecked<2>();
        for (py::ssize_t k = 0; k < yields.shape(0); ++k) ys.push_back({y(k, 0), y(k, 1), y(k, 2), y(k, 3)});
        std::vector<nm::Summary> out(views.size() * ys.size() * signs.size());
        bindings::without_gil([&] {
          nm::sweep(views, ys, signs, which, threads, out.data());
          return 0;
        });
        py::array_t<double> table(std::vector<py::ssize_t>{
            static_cast<py::ssize_t>(views.size()), static_cast<py::ssize_t>(ys.size()),
            static_cast<py::ssize_t>(signs.size()), 4});
        double* t = table.mutable_data();
        for (std::size_t k = 0; k < out.size(); ++k) {
          t[4 * k] = out[k].displacement;
          t[4 * k + 1] = out[k].max_displacement;
          t[4 * k + 2] = out[k].min_displacement;
          t[4 * k + 3] = static_cast<double>(out[k].slips);
        }
        return table;
      },
      py::arg("records"), py::arg("dts"), py::arg("yields"), py::arg("signs"),
      py::arg("method"), py::arg("threads") = 0,
      "Every (record, yield, sign): an array (records, yields, signs, 4) of (displacement, "
      "max, min, slips). yields rows (kd, ku, sd, su) in m/s^2 for 'exact', (ky in g, ...) for "
      "'slammer'. Threads do not change the numbers; the GIL is released.");
}
