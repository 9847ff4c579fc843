// The project's own exp, log, log1p and log erfc for any argument: the same bits on every CPU.
//
// detmath.hpp covers the generator's inputs only, branch-free for the vector loops. These are
// its scalar companions for the tail estimators' weights (splitting's running product is plain
// +,-,*,/; importance sampling's per-path log weights call these through _core.det_exp and the
// like): fdlibm's algorithms (e_exp.c, e_log.c, s_log1p.c, s_erf.c), using only +, -, *, /
// (correctly rounded in IEEE 754 binary64), comparisons and exact operations on the bits, in a
// fixed order, compiled without floating-point contraction (-ffp-contract=off, CMakeLists.txt)
// in cpp/src/detfunc.cpp, never inlined into code compiled otherwise.
//
// Special cases: NaN gives NaN; exp(+inf) = +inf, exp(-inf) = 0, exp overflows to +inf above
// 709.78 and underflows (through the subnormals) to 0 below -745.13; log(0) = log1p(-1) = -inf,
// log(+inf) = log1p(+inf) = +inf, and below the domain (log of a negative number, log1p below
// -1) NaN; log_erfc(-inf) = log 2, log_erfc(+inf) = -inf, and log_erfc(x) stays finite until
// -x^2 itself overflows (x above 1.3e154), where -inf is its correct rounding.
//
// Accuracy, measured against long double (cpp/tests/test_detfunc.cpp) and mpmath
// (tests/test_detfunc.py): see those tests for the bounds.
//
// The algorithms and constants are fdlibm's:
//   Copyright (C) 1993, 2004 by Sun Microsystems, Inc. All rights reserved.
//   Developed at SunSoft, a Sun Microsystems, Inc. business. Permission to use, copy, modify,
//   and distribute this software is freely granted, provided that this notice is preserved.
#pragma once

namespace crandall {
namespace detfunc {

double exp(double x);
double log(double x);
double log1p(double x);
// log(erfc(x)), with no underflow of erfc: for large x from the logarithm of fdlibm's
// erfc(x) = exp(-x^2 - 0.5625 + R/S) / x.
double log_erfc(double x);

}  // namespace detfunc
}  // namespace crandall
