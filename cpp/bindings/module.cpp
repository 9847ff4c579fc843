#include <stdexcept>

#include "common.hpp"
#include "crandall/dispatch.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "crandall's compiled core (private; use the crandall package)";
  // The kernel variant: CRANDALL_ISA or the best the CPU supports, chosen here so that a bad
  // CRANDALL_ISA fails the import with its message rather than the first simulation.
  try {
    crandall::active_kernel();
  } catch (const std::invalid_argument& e) {
    throw py::import_error(e.what());
  }
  register_histogram(m);  // before register_plan: Options holds BinEdges
  register_plan(m);
  register_moments(m);
  register_run(m);
  register_diagnostics(m);
  register_levels(m);
  register_branch(m);
  register_newmark(m);
  register_detfunc(m);
}
