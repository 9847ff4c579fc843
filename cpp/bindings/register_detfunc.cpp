// The deterministic exp, log, log1p and log erfc (crandall/detfunc.hpp) on float64 arrays: the
// tail estimators' weights in Python (crandall/tail/detmath.py) call these instead of NumPy's
// or libm's, whose last bit depends on the CPU.
#include <stdexcept>
#include <string>

#include "common.hpp"
#include "crandall/detfunc.hpp"

namespace {

using Input = py::array_t<double, py::array::c_style | py::array::forcecast>;

// f applied elementwise to a (any shape; a scalar gives a 0-d array). A NaN from an argument
// that is not NaN (outside the function's domain) raises ValueError naming the argument.
template <double (*F)(double)>
py::array_t<double> apply(const char* name, const Input& a) {
  std::vector<py::ssize_t> shape(a.shape(), a.shape() + a.ndim());
  py::array_t<double> out(shape);
  const double* in = a.data();
  double* o = out.mutable_data();
  const auto n = a.size();
  for (py::ssize_t i = 0; i < n; ++i) {
    const double y = F(in[i]);
    if (y != y && in[i] == in[i])
      throw py::value_error(std::string(name) + ": " + py::repr(py::float_(in[i])).cast<std::string>() +
                            " is outside the function's domain");
    o[i] = y;
  }
  return out;
}

}  // namespace

void register_detfunc(py::module_& m) {
  m.def(
      "det_exp", [](const Input& a) { return apply<crandall::detfunc::exp>("det_exp", a); },
      py::arg("x"),
      "exp(x) elementwise with the same bits on every CPU (fdlibm's algorithm with +, -, *, / "
      "only): +inf above 709.78, 0 below -745.13, NaN for NaN.");
  m.def(
      "det_log", [](const Input& a) { return apply<crandall::detfunc::log>("det_log", a); },
      py::arg("x"),
      "log(x) elementwise with the same bits on every CPU: -inf at 0, ValueError below 0.");
  m.def(
      "det_log1p", [](const Input& a) { return apply<crandall::detfunc::log1p>("det_log1p", a); },
      py::arg("x"),
      "log(1 + x) elementwise with the same bits on every CPU: -inf at -1, ValueError below.");
  m.def(
      "det_log_erfc",
      [](const Input& a) { return apply<crandall::detfunc::log_erfc>("det_log_erfc", a); },
      py::arg("x"),
      "log(erfc(x)) elementwise with the same bits on every CPU, without underflow for large "
      "x (-inf only where -x^2 overflows).");
}
