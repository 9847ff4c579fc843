#include <string>

#include "common.hpp"
#include "crandall/plan.hpp"

void register_plan(py::module_& m) {
  m.attr("CHUNK_PATHS") = crandall::kChunkPaths;
  m.attr("BLOCK_PATHS") = crandall::kBlockPaths;
  m.attr("LANES") = crandall::kLanes;
  m.attr("HISTOGRAM_VARIABLES") = crandall::kHistogramVariables;
  // The methods' table (plan.hpp's kMethodTable), one row (name, grids, skeleton, order) per
  // method in the core's order, the order NaN where it is not known: the Python layer
  // (crandall.methods) reads it from here instead of keeping a copy. METHOD_GRIDS is its
  // name -> grids view.
  py::list method_table;
  py::dict method_grids;
  for (crandall::Method method : crandall::kMethods) {
    method_table.append(py::make_tuple(crandall::method_name(method), crandall::grids(method),
                                       crandall::skeleton(method), crandall::method_order(method)));
    method_grids[crandall::method_name(method)] = crandall::grids(method);
  }
  m.attr("METHOD_TABLE") = py::tuple(method_table);
  m.attr("METHOD_GRIDS") = method_grids;
  m.def(
      "richardson_weights",
      [](const std::string& method) { return crandall::richardson_weights(crandall::parse_method(method)); },
      py::arg("method"),
      "The weights that combine a method's coupled grids (steps h, 2h, 4h), finest first.");

  py::class_<crandall::Options>(m, "Options", "Options of a run (validated by Plan).")
      .def(py::init<>())
      .def_readwrite("drift", &crandall::Options::drift)
      .def_readwrite("noise", &crandall::Options::noise)
      .def_readwrite("switch_off", &crandall::Options::switch_off)
      .def_readwrite("piece_ends", &crandall::Options::piece_ends)
      .def_readwrite("piece_noise", &crandall::Options::piece_noise)
      .def_readwrite("residual", &crandall::Options::residual)
      .def_readwrite("quadratic_variation", &crandall::Options::quadratic_variation)
      .def_readwrite("start_velocity", &crandall::Options::start_velocity)
      .def_readwrite("start_displacement", &crandall::Options::start_displacement)
      .def_readwrite("times", &crandall::Options::times)
      .def_readwrite("dt", &crandall::Options::dt)
      .def_readwrite("min_steps", &crandall::Options::min_steps)
      .def_readwrite("refinement", &crandall::Options::refinement)
      .def_property(
          "method",
          [](const crandall::Options& o) { return std::string(crandall::method_name(o.method)); },
          [](crandall::Options& o, const std::string& name) { o.method = crandall::parse_method(name); })
      .def_readwrite("velocity", &crandall::Options::velocity)
      .def_readwrite("displacement", &crandall::Options::displacement)
      .def_readwrite("distance", &crandall::Options::distance)
      .def_readwrite("stop", &crandall::Options::stop)
      .def_readwrite("peaks", &crandall::Options::peaks)
      .def_readwrite("energy", &crandall::Options::energy)
      // A list of BinEdges, index slot * 5 + variable (plan.hpp); assign a whole list (the
      // attribute returns a copy, so appending to it changes nothing).
      .def_readwrite("histogram_axes", &crandall::Options::histogram_axes)
      .def_readwrite("seed", &crandall::Options::seed)
      .def_readwrite("paths", &crandall::Options::paths)
      // The filtered excitation (plan.hpp): excitation is "white" or "filtered".
      .def_property(
          "excitation",
          [](const crandall::Options& o) { return std::string(crandall::excitation_name(o.excitation)); },
          [](crandall::Options& o, const std::string& name) { o.excitation = crandall::parse_excitation(name); })
      .def_readwrite("filter_a", &crandall::Options::filter_a)
      .def_readwrite("filter_b", &crandall::Options::filter_b)
      .def_readwrite("filter_c", &crandall::Options::filter_c)
      .def_readwrite("filter_start", &crandall::Options::filter_start)
      .def_readwrite("static_drift", &crandall::Options::static_drift)
      .def_readwrite("event_depth", &crandall::Options::event_depth)
      .def_readwrite("ring_down", &crandall::Options::ring_down)
      .def("validate", &crandall::Options::validate);

  py::class_<crandall::Plan>(m, "Plan", "A validated run: the time grid and the path partition.")
      .def(py::init<crandall::Options>(), py::arg("options"))
      .def_property_readonly("steps_per_path", &crandall::Plan::steps_per_path)
      .def_property_readonly("chunks", &crandall::Plan::chunks)
      .def("chunk_paths", &crandall::Plan::chunk_paths, py::arg("chunk"))
      .def_property_readonly("options", &crandall::Plan::options);
}
