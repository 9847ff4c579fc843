#include "crandall/plan.hpp"

#include <cmath>
#include <stdexcept>

namespace crandall {
namespace {

void require(bool ok, const std::string& message) {
  if (!ok) throw std::invalid_argument(message);
}

}  // namespace

void Options::validate() const {
  require(std::isfinite(drift) && drift >= 0.0, "drift must be finite and >= 0");
  require(std::isfinite(noise) && noise >= 0.0, "noise must be finite and >= 0");
  require(!std::isnan(switch_off) && switch_off >= 0.0,
          "switch_off must be >= 0 (or +inf for never)");
  for (std::size_t i = 0; i < times.size(); ++i) {
    require(std::isfinite(times[i]) && times[i] >= 0.0, "times must be finite and >= 0");
    require(i == 0 || times[i] > times[i - 1], "times must be strictly increasing");
  }
  require(std::isfinite(dt) && dt > 0.0, "dt must be finite and > 0");
  require(paths >= 1, "paths must be >= 1");
  require(velocity || displacement || distance || stop, "observe at least one quantity");
  require(!times.empty() || stop, "times must not be empty unless only the stop is observed");
  if (stop) {
    require(std::isfinite(switch_off), "the stop needs a finite switch_off (t0)");
    require(drift > 0.0 || noise == 0.0, "without friction the body never stops");
  }
}

Plan::Plan(Options options) : options_(std::move(options)) {
  options_.validate();
  const Options& o = options_;
  const bool any_after = !o.times.empty() && o.times.back() > o.switch_off;
  needs_switch_state_ = o.stop || any_after;
  const double end = needs_switch_state_ ? o.switch_off : o.times.back();
  // Internal steps are needed for the time integrals, and for Euler-Maruyama always; the
  // exact velocity step is exact for any length, so velocity-only scenes jump.
  const bool fine = o.integrals() || o.method == Method::euler;
  double previous = 0.0;
  long slot = 0;
  auto add = [&](double until, long s) {
    const double gap = until - previous;
    std::uint64_t n = 0;
    if (gap > 0.0) {
      const double want = fine ? std::ceil(gap / o.dt * (1.0 - 1e-12)) : 1.0;
      require(want < 9.0e15, "dt is too small for the horizon: the grid would not fit in 2^53 steps");
      n = want < 1.0 ? 1 : static_cast<std::uint64_t>(want);
    }
    segments_.push_back({n > 0 ? gap / static_cast<double>(n) : 0.0, n, s});
    steps_per_path_ += n;
    previous = until;
  };
  for (; slot < static_cast<long>(o.times.size()) && o.times[slot] <= end; ++slot)
    add(o.times[slot], slot);
  if (previous < end) add(end, -1);
  for (; slot < static_cast<long>(o.times.size()); ++slot) {
    coast_slots_.push_back(slot);
    coast_elapsed_.push_back(o.times[slot] - o.switch_off);
  }
}

std::uint64_t Plan::chunk_paths(std::uint64_t chunk) const {
  require(chunk < chunks(), "chunk index out of range");
  const std::uint64_t first = chunk * kChunkPaths;
  const std::uint64_t left = options_.paths - first;
  return left < kChunkPaths ? left : kChunkPaths;
}

}  // namespace crandall
