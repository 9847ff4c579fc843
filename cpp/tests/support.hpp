// What several C++ tests share: a small scene, and a guard for tests that switch the kernel
// variant.
#pragma once

#include <string>

#include "crandall/dispatch.hpp"
#include "crandall/plan.hpp"

// Every observable, a switch-off between output times, and a path count that fills no block or
// lane group exactly.
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

// Restores the variant in use when a test that forces others ends, even by a failed assertion.
struct KeepKernel {
  std::string name = crandall::active_kernel().name;
  ~KeepKernel() { crandall::select_kernel(name); }
};
