#include <stdexcept>
#include <string>
#include <vector>

#include "common.hpp"
#include "crandall/accumulators.hpp"

namespace {

using crandall::Moments;
using bindings::to_array;
using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

std::vector<double> from_array(const InArray& a, std::size_t expected, const char* name) {
  if (static_cast<std::size_t>(a.size()) != expected)
    throw std::invalid_argument(std::string(name) + " has the wrong size for these slots");
  return std::vector<double>(a.data(), a.data() + a.size());
}

Moments moments_from(std::size_t slots, const InArray& counts, const InArray& means,
                     const InArray& central) {
  Moments m(slots);
  m.counts() = from_array(counts, slots, "counts");
  m.means() = from_array(means, slots * crandall::kVariables, "means");
  m.central() = from_array(central, slots * crandall::kMonomials, "central");
  return m;
}

}  // namespace

void register_moments(py::module_& m) {
  m.def("monomial_exponents", [] {
    py::list out;
    for (const auto& e : crandall::monomial_exponents()) out.append(py::make_tuple(e[0], e[1], e[2]));
    return out;
  }, "Exponent triples (a, b, c) of the central sums, in storage order.");

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
}
