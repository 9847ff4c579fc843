#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "common.hpp"
#include "crandall/histogram.hpp"

namespace {

using crandall::BinEdges;
using InArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

BinEdges edges_from(const InArray& a) {
  if (a.ndim() != 1) throw std::invalid_argument("edges must be a 1-D array");
  return BinEdges::from_edges(std::vector<double>(a.data(), a.data() + a.size()));
}

// Pickled as the edges and the automatic scheme's parameters. An automatic axis is rebuilt by
// log_linear from its base b (a power of two, so its own scale) and max_scales = top / b (a
// power of two: b * (top / b) = top exactly), which gives the same edges and the fast lookup;
// the rebuilt edges are checked against the pickled ones.
py::tuple edges_state(const BinEdges& e) {
  return py::make_tuple(bindings::to_array(e.edges(), e.edges().size(), 0), e.automatic(),
                        e.base(), e.per_octave(), e.symmetric());
}

BinEdges edges_from_state(const py::tuple& t) {
  if (t.size() != 5) throw std::invalid_argument("BinEdges: bad pickle state");
  const auto edges = t[0].cast<InArray>();
  if (edges.size() == 0) return BinEdges();
  if (!t[1].cast<bool>()) return edges_from(edges);
  const double base = t[2].cast<double>();
  const double top = edges.data()[edges.size() - 1];
  BinEdges e = BinEdges::log_linear(base, t[3].cast<int>(), top / base, t[4].cast<bool>());
  if (e.edges().size() != static_cast<std::size_t>(edges.size()) ||
      std::memcmp(e.edges().data(), edges.data(), e.edges().size() * sizeof(double)) != 0)
    throw std::invalid_argument("BinEdges: pickled edges do not match their parameters");
  return e;
}

}  // namespace

void register_histogram(py::module_& m) {
  m.attr("MAX_HISTOGRAM_BINS") = crandall::kMaxHistogramBins;
  py::class_<BinEdges>(
      m, "BinEdges",
      "The edges of one histogram axis. Bins are half-open [e_j, e_j+1); counts are stored as "
      "underflow, the bins, overflow, NaN (cells = bins + 3). An empty axis (0 bins) means "
      "'not recorded'.")
      .def(py::init<>())
      .def_static("log_linear", &BinEdges::log_linear, py::arg("scale"), py::arg("per_octave"),
                  py::arg("max_scales"), py::arg("symmetric"),
                  "Automatic log-linear edges: linear bins of width b / per_octave below the "
                  "power of two b <= scale < 2b, then per_octave bins per octave up to at least "
                  "max_scales * scale; mirrored at 0 if symmetric; and the edge 2^-1074 just above 0, so "
                  "that the bin [0, 2^-1074) holds exact zeros only.")
      .def_static("from_edges", &edges_from, py::arg("edges"),
                  "Any strictly increasing finite edges (at least two).")
      .def_property_readonly("edges", [](const BinEdges& e) {
        return bindings::to_array(e.edges(), e.edges().size(), 0);
      })
      .def_property_readonly("bins", &BinEdges::bins)
      .def_property_readonly("cells", [](const BinEdges& e) { return e.bins() == 0 ? 0 : e.cells(); })
      .def_property_readonly("automatic", &BinEdges::automatic)
      .def_property_readonly("base", &BinEdges::base)
      .def_property_readonly("per_octave", &BinEdges::per_octave)
      .def_property_readonly("symmetric", &BinEdges::symmetric)
      .def(
          "cell",
          [](const BinEdges& e, double x) {
            if (e.bins() == 0) throw std::invalid_argument("BinEdges.cell: the axis has no bins");
            return e.cell(x);
          },
          py::arg("x"),
          "The cell of x: 0 underflow, 1 + j for bin j, bins + 1 overflow, bins + 2 NaN.")
      .def(
          "count",
          [](const BinEdges& e, const InArray& values) {
            if (e.bins() == 0) throw std::invalid_argument("BinEdges.count: the axis has no bins");
            if (values.ndim() != 1) throw std::invalid_argument("values must be a 1-D array");
            py::array_t<std::uint64_t> out(static_cast<py::ssize_t>(e.cells()));
            std::uint64_t* c = out.mutable_data();
            std::fill(c, c + e.cells(), std::uint64_t{0});
            const double* x = values.data();
            const std::size_t n = static_cast<std::size_t>(values.size());
            for (std::size_t i = 0; i < n; ++i) ++c[e.cell(x[i])];
            return out;
          },
          py::arg("values"),
          "Counts of the values in the cells (underflow, the bins, overflow, NaN), with the "
          "lookup the run uses: the same counts a run gives for the same values.")
      .def(py::self == py::self)
      .def(py::self != py::self)
      .def("__repr__",
           [](const BinEdges& e) {
             if (e.bins() == 0) return std::string("BinEdges()");
             if (e.automatic())
               return "BinEdges(log_linear: base=" + std::to_string(e.base()) +
                      ", per_octave=" + std::to_string(e.per_octave()) +
                      ", bins=" + std::to_string(e.bins()) +
                      (e.symmetric() ? ", symmetric)" : ", one-sided)");
             return "BinEdges(from_edges: bins=" + std::to_string(e.bins()) + ")";
           })
      .def(py::pickle(&edges_state, &edges_from_state));
}
