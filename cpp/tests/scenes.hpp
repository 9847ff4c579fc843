// The small scene several C++ tests run: every observable, a switch-off between output times,
// and a path count that fills no block or lane group exactly.
#pragma once

#include "crandall/plan.hpp"

inline crandall::Options scene() {
  crandall::Options o;
  o.switch_off = 1.0;
  o.times = {0.25, 0.5, 1.0, 1.5};
  o.dt = 0.05;
  o.displacement = o.distance = o.stop = true;
  o.seed = 42;
  o.paths = 3000;  // not a multiple of the block or lane size: partial blocks are exercised
  return o;
}
