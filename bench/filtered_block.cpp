// The filtered excitation's path block on one thread, and the paired check that the event
// search misses no event (docs/filtered.md, "Events"). Build against a build directory's
// static library, e.g.
//   g++ -O2 -std=c++17 -fopenmp -Icpp/include -Ithird_party/Random123/include -I/usr/include/eigen3 \
//       bench/filtered_block.cpp build-s/libcrandall_core.a -o /tmp/filtered_block
//   /tmp/filtered_block time 8192            the probe's scenes: ns per skeleton step
//   /tmp/filtered_block default 8192         the same at bench/filtered.py's default steps (0.2,
//                                            0.2, 0.125 s, at least 64 steps to t0): us per path
//   /tmp/filtered_block save 20000 FILE 2 2  per-path (stop time, distance) with the margin x2
//                                            and depth + 2 (binary), for `bias` against another build
//   /tmp/filtered_block bias 20000           paired differences: default against margin x2 and
//                                            depth + 2 of this build
//   /tmp/filtered_block bias 20000 FILE 1 0  margin x1 and depth + 0 of this build against FILE
// Scenes: Kanai-Tajimi omega t* = 1, 4, 16 (omega = wt / 2), zeta 0.6, h = 1, mu g = 1, t0 = 10.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "crandall/filter.hpp"
#include "crandall/filtered.hpp"
#include "crandall/levels.hpp"
#include "crandall/run.hpp"

namespace {

crandall::Options scene(double wt, std::uint64_t paths, int depth, bool default_step = false) {
  const auto f = crandall::kanai_tajimi(wt / 2, 0.6);
  crandall::Options o;
  o.excitation = crandall::Excitation::filtered;
  o.filter_a = f.a;
  o.filter_b = f.b;
  o.filter_c = f.c;
  o.drift = 1.0;
  o.static_drift = std::nan("");
  o.noise = 1.0;
  o.dt = default_step ? (wt == 16.0 ? 0.125 : 0.2) : wt == 16.0 ? 0.0125 : 0.02;
  o.min_steps = 64;
  o.times = {10.0};
  o.switch_off = 10.0;
  o.distance = o.stop = true;
  o.seed = 1;
  o.paths = paths;
  o.event_depth = depth;
  return o;
}

// Per path: stop time - t0, distance at the stop.
std::vector<double> samples(double wt, std::uint64_t paths, double margin, int depth) {
  const double old = crandall::set_event_margin(margin);
  const crandall::Plan plan(scene(wt, paths, depth));
  const std::size_t size = crandall::sample_size(plan);
  std::vector<double> out(paths * size);
  crandall::run_samples(plan, 0, paths, 2, out.data());
  crandall::set_event_margin(old);
  std::vector<double> r(2 * paths);
  for (std::size_t p = 0; p < paths; ++p) {
    r[2 * p] = out[p * size + 3];
    r[2 * p + 1] = out[p * size + 5];
  }
  return r;
}

void paired(const char* what, const std::vector<double>& a, const std::vector<double>& b, int col) {
  const std::size_t n = a.size() / 2;
  double ma = 0, mb = 0;
  for (std::size_t p = 0; p < n; ++p) ma += a[2 * p + col], mb += b[2 * p + col];
  ma /= n, mb /= n;
  double sd = 0, sd2 = 0, sv = 0, sv2 = 0, va = 0;
  for (std::size_t p = 0; p < n; ++p) {
    const double x = a[2 * p + col], y = b[2 * p + col];
    const double d = x - y, dv = (x - ma) * (x - ma) - (y - mb) * (y - mb);
    sd += d, sd2 += d * d, sv += dv, sv2 += dv * dv, va += (x - ma) * (x - ma);
  }
  const double md = sd / n, se = std::sqrt((sd2 / n - md * md) / n);
  const double mv = sv / n, sev = std::sqrt((sv2 / n - mv * mv) / n);
  std::printf("  %-9s mean %.6f  diff %+.3e (se %.1e, %+.2f se)   var %.6f  diff %+.3e (se %.1e, %+.2f se)\n",
              what, ma, md, se, se > 0 ? md / se : 0.0, va / n, mv, sev, sev > 0 ? mv / sev : 0.0);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "time";
  const std::uint64_t paths = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 8192;
  const double wts[] = {1.0, 4.0, 16.0};
  if (mode == "time" || mode == "default") {
    const bool default_step = mode == "default";
    for (double wt : wts) {
      const crandall::Plan plan(scene(wt, paths, crandall::kDefaultEventDepth, default_step));
      double best = 1e300;
      for (int rep = 0; rep < 3; ++rep) {
        const auto t0 = std::chrono::steady_clock::now();
        crandall::run_chunk(plan, 0, 1);
        const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        best = std::min(best, el);
      }
      const double steps = default_step ? (wt == 16.0 ? 80.0 : 64.0) : 10.0 / (wt == 16.0 ? 0.0125 : 0.02);
      std::printf("wt %4.0f  us/path %7.1f  ns/skeleton step %6.0f\n", wt, best / paths * 1e6,
                  best / paths / steps * 1e9);
    }
    return 0;
  }
  const double mult = argc > 4 ? std::atof(argv[4]) : mode == "bias" ? 1.0 : 2.0;
  const int add = argc > 5 ? std::atoi(argv[5]) : mode == "bias" ? 0 : 2;
  if (mode == "save") {
    FILE* f = std::fopen(argv[3], "wb");
    for (double wt : wts) {
      const auto r = samples(wt, paths, crandall::kEventMargin * mult, crandall::kDefaultEventDepth + add);
      std::fwrite(r.data(), sizeof(double), r.size(), f);
    }
    std::fclose(f);
    return 0;
  }
  FILE* f = argc > 3 ? std::fopen(argv[3], "rb") : nullptr;
  for (double wt : wts) {
    // (with FILE: this build's margin x mult and depth + add against it)
    const auto a = f ? samples(wt, paths, crandall::kEventMargin * mult, crandall::kDefaultEventDepth + add)
                     : samples(wt, paths, crandall::kEventMargin, crandall::kDefaultEventDepth);
    std::vector<double> b;
    if (f) {
      b.resize(a.size());
      if (std::fread(b.data(), sizeof(double), b.size(), f) != b.size()) return 1;
    } else {
      b = samples(wt, paths, crandall::kEventMargin * 2, crandall::kDefaultEventDepth + 2);
    }
    std::printf("wt %g, %llu paths: default minus %s\n", wt, static_cast<unsigned long long>(paths),
                f ? argv[3] : "margin x2, depth + 2");
    paired("stop time", a, b, 0);
    paired("distance", a, b, 1);
  }
  return 0;
}
