// The one pybind11 include of the bindings (one place for the includes avoids ODR trouble).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

namespace py = pybind11;

void register_run(py::module_& m);
