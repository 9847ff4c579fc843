#include "common.hpp"

PYBIND11_MODULE(_core, m) {
  m.doc() = "crandall's compiled core (private; use the crandall package)";
  register_run(m);
}
