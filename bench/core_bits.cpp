// Prints every double a few runs of the core produce, as hexadecimal bits, one per line:
// the white-noise kernel (run_chunk with the exact method, its stop, peaks, energy and
// residual; a Richardson run on pieces; run_samples' per-path values with the control sums and
// the quadratic variation), splitting's path continuation (extend_paths) and replicas
// (split_replicas), the filtered walker (a Kanai-Tajimi and a Clough-Penzien plan with the
// stop, run_chunk and run_samples, the second ringing down) and Newmark's block on a record
// (the exact integrator and pySLAMMER's recursion, with their histories). bench/core_bits.sh
// builds it for x86-64 and for aarch64 (run under qemu) and compares the outputs bit by bit
// (docs/filtered.md, "The same doubles on every CPU"). Usage: core_bits [ISA] (ISA: a kernel
// variant to force, as CRANDALL_ISA; default the best one this CPU runs).
#include <cinttypes>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "crandall/branch.hpp"
#include "crandall/detfunc.hpp"
#include "crandall/dispatch.hpp"
#include "crandall/exact_step.hpp"
#include "crandall/filter.hpp"
#include "crandall/levels.hpp"
#include "crandall/newmark.hpp"
#include "crandall/plan.hpp"
#include "crandall/run.hpp"
#include "crandall/split.hpp"

namespace {

void print(const std::string& label, const double* v, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    std::uint64_t bits;
    std::memcpy(&bits, &v[i], sizeof bits);
    std::printf("%s[%zu] %016" PRIx64 " %.17g\n", label.c_str(), i, bits, v[i]);
  }
}

void print(const std::string& label, const std::vector<double>& v) {
  print(label, v.data(), v.size());
}

void print(const std::string& label, const crandall::Moments& m) {
  print(label + " count", m.counts());
  print(label + " mean", m.means());
  print(label + " central", m.central());
}

void print(const std::string& label, const crandall::ChunkResult& r) {
  print(label + " times", r.times);
  print(label + " stop", r.stop);
  print(label + " peaks", r.peaks);
  print(label + " peaks_stop", r.peaks_stop);
  print(label + " energy", r.energy);
}

// Every chunk of the plan, in order (the threads' count does not change a bit: 2 here).
void chunks(const std::string& label, const crandall::Options& o) {
  const crandall::Plan plan(o);
  for (std::uint64_t c = 0; c < plan.chunks(); ++c)
    print(label + " chunk" + std::to_string(c), crandall::run_chunk(plan, c, 2));
}

void samples(const std::string& label, const crandall::Options& o, std::uint64_t count,
             bool controls) {
  const crandall::Plan plan(o);
  const std::size_t size = crandall::sample_size(plan);
  std::vector<double> out(count * size);
  std::vector<double> sums(controls ? count * (o.times.size() + o.stop_slots()) *
                                          static_cast<std::size_t>(crandall::control_count())
                                    : 0);
  crandall::run_samples(plan, 0, count, 2, out.data(), controls ? sums.data() : nullptr);
  print(label + " samples", out);
  if (controls) print(label + " controls", sums);
}

crandall::Options white() {
  crandall::Options o;
  o.times = {0.25, 1.0, 2.5, 4.0};
  o.switch_off = 3.0;
  o.dt = 0.01;
  o.displacement = o.distance = o.stop = o.residual = true;
  o.seed = 20260101;
  o.paths = 4096;
  return o;
}

crandall::Options filtered(const crandall::LinearFilter& f) {
  crandall::Options o;
  o.excitation = crandall::Excitation::filtered;
  o.filter_a = f.a;
  o.filter_b = f.b;
  o.filter_c = f.c;
  o.drift = 2.0;
  o.static_drift = 2.5;
  o.times = {0.5, 1.0, 2.5};
  o.switch_off = 2.0;
  o.dt = 0.02;
  o.displacement = o.distance = o.stop = true;
  o.seed = 77;
  o.paths = 2048;
  return o;
}

void white_noise() {
  auto o = white();
  o.peaks = o.energy = true;
  chunks("white exact", o);

  auto r = white();
  r.method = crandall::Method::richardson;
  r.piece_ends = {1.0, 1.5, 3.0};
  r.piece_noise = {1.4142135623730951, 0.0, 0.8};
  r.paths = 2048;
  chunks("white richardson pieces", r);

  auto s = white();
  s.residual = false;
  s.quadratic_variation = true;
  samples("white exact samples", s, 512, true);
}

void continuation() {
  const std::size_t steps = 200, rows = 64;
  std::vector<double> lengths(steps), noises(steps), drifts(steps);
  for (std::size_t k = 0; k < steps; ++k) {
    lengths[k] = k < 150 ? 0.02 : 0.05;
    noises[k] = k < 150 ? 1.4142135623730951 : 0.0;
    drifts[k] = k < 100 ? 2.0 : 1.5;
  }
  const crandall::BranchGrid grid{lengths.data(), noises.data(), drifts.data(), steps};
  std::vector<double> states(rows * (steps + 1) * 3, 0.0);
  std::vector<std::int64_t> ids(rows), starts(rows, 0);
  std::vector<std::uint64_t> streams(rows);
  for (std::size_t i = 0; i < rows; ++i) {
    ids[i] = static_cast<std::int64_t>(i);
    streams[i] = 1000 + i;
  }
  std::vector<std::uint8_t> touched(rows * steps);
  crandall::extend_paths(states.data(), rows, grid, ids.data(), starts.data(), streams.data(),
                         rows, 99, 2, touched.data());
  // Continue every other row again from a midway point (splitting's branching).
  std::vector<std::int64_t> half, mid;
  std::vector<std::uint64_t> fresh;
  for (std::size_t i = 0; i < rows; i += 2) {
    half.push_back(static_cast<std::int64_t>(i));
    mid.push_back(static_cast<std::int64_t>(40 + 2 * (i % 30)));
    fresh.push_back(5000 + i);
  }
  crandall::extend_paths(states.data(), rows, grid, half.data(), mid.data(), fresh.data(),
                         half.size(), 99, 2, nullptr);
  print("extend_paths states", states);
  std::vector<double> t(touched.begin(), touched.end());
  print("extend_paths touched", t);
}

// Splitting's replicas in the core (split_replicas: clones continued in the vector lanes), for the
// stop time of a white-noise path on a grid of 100 steps.
void splitting() {
  const std::size_t steps = 100;
  std::vector<double> lengths(steps, 0.03), noises(steps, 1.4142135623730951), drifts(steps, 2.0);
  const crandall::BranchGrid grid{lengths.data(), noises.data(), drifts.data(), steps};
  crandall::SplitScore score;
  score.quantity = crandall::SplitQuantity::stop_time;
  score.drift = 2.0;
  score.horizon = 3.0;
  score.normalised_rank = crandall::active_kernel().normalised_rank;
  const std::vector<double> levels = {3.5, 4.0, 4.5};
  crandall::SplitRun run;
  run.particles = 200;
  run.kill = 20;
  run.key = 31337;
  run.max_iterations = 100000;
  run.levels = run.thresholds = levels.data();
  run.level_count = levels.size();
  run.threads = 2;
  const std::vector<std::uint64_t> replicas = {0, 1, 2, 3};
  const auto outcomes = crandall::split_replicas(grid, score, run, replicas.data(), replicas.size());
  for (std::size_t r = 0; r < outcomes.size(); ++r) {
    const auto& o = outcomes[r];
    const std::string p = "split_replicas stop_time replica" + std::to_string(r);
    print(p + " estimates", o.estimates);
    print(p + " counts", std::vector<double>{double(o.iterations), double(o.steps), o.log_weight,
                                             double(o.extinct), double(o.timed_out)});
  }
}

void filtered_plans() {
  auto kt = filtered(crandall::kanai_tajimi(15.6, 0.6));
  kt.noise = 0.6;
  kt.peaks = true;
  chunks("kanai_tajimi(15.6,0.6) stop", kt);
  samples("kanai_tajimi(15.6,0.6) stop", kt, 256, false);

  auto cp = filtered(crandall::clough_penzien(5.0, 0.6, 0.5, 0.6));
  cp.noise = 1.0;
  cp.ring_down = true;
  chunks("clough_penzien(5,0.6,0.5,0.6) ring_down stop", cp);
  samples("clough_penzien(5,0.6,0.5,0.6) ring_down stop", cp, 256, false);
}

// A synthetic record with exactly representable samples (integers times 2^-10, a mean-reverting
// integer walk): no libm call or rounding in the driver decides its values.
std::vector<double> record(std::size_t n) {
  std::vector<double> a(n);
  std::uint64_t x = 88172645463325252ull;
  std::int64_t k = 0;
  for (std::size_t i = 0; i < n; ++i) {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    k += static_cast<std::int64_t>(x % 801) - 400 - k / 8;
    a[i] = static_cast<double>(k) / 1024.0;
  }
  return a;
}

void records() {
  namespace nm = crandall::newmark;
  const std::vector<double> a = record(4000);
  const double dt = 0.005;
  const std::vector<nm::Yield> yields = {
      {0.5, 1e300 * 1e300, 0.5, 1e300 * 1e300}, {0.8, 0.8, 1.0, 1.0}, {1.5, 1.2, 1.5, 1.2}};
  for (std::size_t k = 0; k < yields.size(); ++k) {
    for (double sign : {1.0, -1.0}) {
      std::vector<double> w(a.size()), d(a.size());
      std::vector<nm::Event> events;
      const nm::Summary s = nm::exact(a.data(), a.size(), dt, sign, yields[k],
                                      nm::History{w.data(), d.data(), &events});
      const std::string p = "newmark exact yield" + std::to_string(k) + (sign > 0 ? "+" : "-");
      print(p + " summary", std::vector<double>{s.displacement, s.max_displacement,
                                                s.min_displacement, double(s.slips)});
      print(p + " velocity", w);
      print(p + " displacement", d);
      std::vector<double> e;
      for (const nm::Event& ev : events) e.insert(e.end(), {ev.onset, ev.stop, double(ev.direction)});
      print(p + " events", e);
    }
  }
  for (double ky : {0.05, 0.1}) {
    std::vector<double> w(a.size()), d(a.size());
    const nm::Summary s = nm::slammer(a.data(), a.size(), dt, 1.0, ky, nm::History{w.data(), d.data(), nullptr});
    const std::string p = "newmark slammer ky" + std::to_string(ky);
    print(p + " summary", std::vector<double>{s.displacement, s.max_displacement,
                                              s.min_displacement, double(s.slips)});
    print(p + " velocity", w);
    print(p + " displacement", d);
  }
}

// The C library's functions the core called (nm -u on the library): exp and log1p (splitting's
// weights, split.cpp) and hypot (the exact step's scaled form, exact_step.hpp, for step lengths
// beyond the regular range); now replaced by the core's own (detfunc.hpp, scaled_root). None is
// correctly rounded by contract, so their bits are the C library's: checked here over many
// arguments (exact doubles made from integers), one hash of the results' bits per function
// (FNV-1a) and, for the splitting weights' log1p(-k / n), every value of the particle counts
// used, beside the core's own detfunc::log1p and scaled_root (which must not differ).
std::uint64_t fnv(std::uint64_t h, double x) {
  std::uint64_t bits;
  std::memcpy(&bits, &x, sizeof bits);
  for (int i = 0; i < 8; ++i) h = (h ^ ((bits >> (8 * i)) & 0xffu)) * 0x100000001b3ull;
  return h;
}

void libm() {
  const std::uint64_t basis = 0xcbf29ce484222325ull;
  std::uint64_t x = 0x9e3779b97f4a7c15ull;
  const auto next = [&x] {
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    return x;
  };
  const std::size_t n = 1000000;
  std::uint64_t he = basis, hh = basis, hl = basis, hs = basis;
  for (std::size_t i = 0; i < n; ++i) {
    // exp over [-745, 0] and [0, 709] in steps of 2^-40; log1p over (-1, 1] in steps of 2^-52;
    // hypot of (-64, 64) in steps of 2^-40 and [0, 64) in steps of 2^-46.
    const double e = static_cast<double>(next() % (1454ull << 40)) / 1099511627776.0 - 745.0;
    he = fnv(he, std::exp(e));
    const double l = static_cast<double>(next() % (2ull << 52)) / 4503599627370496.0 - 1.0 + 0x1p-52;
    hl = fnv(hl, std::log1p(l));
    const double a = static_cast<double>(next() % (128ull << 40)) / 1099511627776.0 - 64.0;
    const double b = static_cast<double>(next() % (64ull << 46)) / 70368744177664.0;
    hh = fnv(hh, std::hypot(a, b));
    hs = fnv(hs, crandall::scaled_root(a, b));
  }
  std::printf("libm exp %zu arguments: hash %016" PRIx64 "\n", n, he);
  std::printf("libm log1p %zu arguments: hash %016" PRIx64 "\n", n, hl);
  std::printf("libm hypot %zu arguments: hash %016" PRIx64 "\n", n, hh);
  std::printf("scaled_root %zu arguments: hash %016" PRIx64 "\n", n, hs);
  for (std::size_t particles : {100, 200, 500, 1000, 2000, 5000, 10000}) {
    std::vector<double> v;
    for (std::size_t k = 1; k < particles; ++k)
      v.push_back(std::log1p(-double(k) / double(particles)));
    print("libm log1p(-k/" + std::to_string(particles) + ")", v);
    v.clear();
    for (std::size_t k = 1; k < particles; ++k)
      v.push_back(crandall::detfunc::log1p(-double(k) / double(particles)));
    print("detfunc log1p(-k/" + std::to_string(particles) + ")", v);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1) crandall::select_kernel(argv[1]);
  std::fprintf(stderr, "kernel variant: %s\n", crandall::active_kernel().name);
  white_noise();
  continuation();
  splitting();
  filtered_plans();
  records();
  libm();
  return 0;
}
