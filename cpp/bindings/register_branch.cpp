#include <cstdint>
#include <string>
#include <vector>

#include "common.hpp"
#include "crandall/branch.hpp"
#include "crandall/filter.hpp"
#include "crandall/filtered.hpp"
#include "crandall/plan.hpp"
#include "crandall/run.hpp"
#include "crandall/split.hpp"

namespace {

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;

void def_extend_paths(py::module_& m) {
  m.def(
      "extend_paths",
      [](py::array states, py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> rows,
         py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> starts,
         py::array_t<std::uint64_t, py::array::c_style | py::array::forcecast> streams,
         py::array_t<double, py::array::c_style | py::array::forcecast> lengths,
         py::array_t<double, py::array::c_style | py::array::forcecast> noises,
         py::array_t<double, py::array::c_style | py::array::forcecast> drifts,
         std::uint64_t key, int threads, py::object touched, py::object slow,
         py::object slow_drifts) {
        if (!states.dtype().is(py::dtype::of<double>()) || states.ndim() != 3 ||
            states.shape(2) != 3 || !(states.flags() & py::array::c_style) || !states.writeable())
          throw std::invalid_argument("states must be a writable C-contiguous float64 array of "
                                      "shape (rows, steps + 1, 3)");
        const auto steps = static_cast<std::size_t>(lengths.size());
        if (noises.size() != lengths.size() || drifts.size() != lengths.size())
          throw std::invalid_argument("lengths, noises and drifts must have one value per step");
        if (states.shape(1) != static_cast<py::ssize_t>(steps + 1))
          throw std::invalid_argument("states must have steps + 1 = " + std::to_string(steps + 1) +
                                      " grid points per row");
        if (starts.size() != rows.size() || streams.size() != rows.size())
          throw std::invalid_argument("rows, starts and streams must have the same length");
        crandall::BranchGrid grid{lengths.data(), noises.data(), drifts.data(), steps};
        using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;
        Doubles slow_a, slow_d;
        if (slow.is_none() != slow_drifts.is_none())
          throw std::invalid_argument("slow and slow_drifts: give both or neither");
        if (!slow.is_none()) {
          slow_a = Doubles::ensure(slow);
          slow_d = Doubles::ensure(slow_drifts);
          if (!slow_a || !slow_d || slow_a.ndim() != 1 || slow_d.ndim() != 1 ||
              static_cast<std::size_t>(slow_a.size()) != steps ||
              static_cast<std::size_t>(slow_d.size()) != steps)
            throw std::invalid_argument("slow and slow_drifts must have one value per step");
          grid.slow = slow_a.data();
          grid.slow_drifts = slow_d.data();
        }
        double* data = static_cast<double*>(states.mutable_data());
        const auto rows_total = static_cast<std::size_t>(states.shape(0));
        const auto count = static_cast<std::size_t>(rows.size());
        std::uint8_t* flags = nullptr;
        if (!touched.is_none()) {
          const char* wrong = "touched must be None or a writable C-contiguous uint8 array of "
                              "shape (rows, steps)";
          if (!py::isinstance<py::array>(touched)) throw std::invalid_argument(wrong);
          auto t = py::reinterpret_borrow<py::array>(touched);
          if (!t.dtype().is(py::dtype::of<std::uint8_t>()) || t.ndim() != 2 || t.shape(0) != static_cast<py::ssize_t>(rows_total) ||
              t.shape(1) != static_cast<py::ssize_t>(steps) || !(t.flags() & py::array::c_style) ||
              !t.writeable())
            throw std::invalid_argument(wrong);
          flags = static_cast<std::uint8_t*>(t.mutable_data());
        }
        bindings::without_gil([&] {
          crandall::extend_paths(data, rows_total, grid, rows.data(), starts.data(), streams.data(),
                                 count, key, threads, flags);
          return 0;
        });
      },
      py::arg("states"), py::arg("rows"), py::arg("starts"), py::arg("streams"),
      py::arg("lengths"), py::arg("noises"), py::arg("drifts"), py::arg("key"),
      py::arg("threads") = 0, py::arg("touched") = py::none(), py::arg("slow") = py::none(),
      py::arg("slow_drifts") = py::none(),
      "Continues rows `rows` of `states` (rows x (steps + 1) x 3: velocity, displacement, "
      "distance at every grid point) from grid point starts[i] to the end of the grid with the "
      "noise of stream streams[i] of `key`; step k has length lengths[k], noise noises[k] and "
      "drift drifts[k]. In place; the GIL is released. touched (optional uint8, rows x steps) "
      "receives whether each step a row takes touched 0 (1) or not (0; a coast step: 0). "
      "slow, slow_drifts (optional, one per step): a step that starts with |x| < slow[k] "
      "takes the drift slow_drifts[k] instead of drifts[k].");
}

void def_extend_filtered_paths(py::module_& m) {
  m.def(
      "extend_filtered_paths",
      [](const crandall::Plan& plan, py::array states,
         py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> rows,
         py::array_t<std::int64_t, py::array::c_style | py::array::forcecast> starts,
         py::array_t<std::uint64_t, py::array::c_style | py::array::forcecast> streams,
         py::object key, int threads) {
        if (!plan.options().filtered())
          throw std::invalid_argument("plan: extend_filtered_paths needs excitation 'filtered'");
        const std::size_t points = crandall::filtered_grid_points(plan);
        const std::size_t cols = crandall::filtered_state_columns(plan);
        if (!states.dtype().is(py::dtype::of<double>()) || states.ndim() != 3 ||
            states.shape(1) != static_cast<py::ssize_t>(points) ||
            states.shape(2) != static_cast<py::ssize_t>(cols) ||
            !(states.flags() & py::array::c_style) || !states.writeable())
          throw std::invalid_argument("states must be a writable C-contiguous float64 array of "
                                      "shape (rows, " + std::to_string(points) + ", " +
                                      std::to_string(cols) + ")");
        if (starts.size() != rows.size() || streams.size() != rows.size())
          throw std::invalid_argument("rows, starts and streams must have the same length");
        const std::uint64_t k = key.is_none() ? plan.options().seed : key.cast<std::uint64_t>();
        double* data = static_cast<double*>(states.mutable_data());
        const auto rows_total = static_cast<std::size_t>(states.shape(0));
        const auto count = static_cast<std::size_t>(rows.size());
        bindings::without_gil([&] {
          crandall::extend_filtered_paths(plan, data, rows_total, rows.data(), starts.data(),
                                          streams.data(), count, k, threads);
          return 0;
        });
      },
      py::arg("plan"), py::arg("states"), py::arg("rows"), py::arg("starts"), py::arg("streams"),
      py::arg("key") = py::none(), py::arg("threads") = 0,
      "Continues rows `rows` of `states` (rows x points x (4 + n): V, U, S, the time of the last "
      "arrival at rest, the filter state z, at every point of a filtered plan's walked grid) "
      "from grid point starts[i] to the plan's last point with the random numbers of path "
      "streams[i] (< 2^40) under `key` (default: the plan's seed, whose path p from point 0 is "
      "the fixed-step block's path p). In place; the GIL is released; the same bits for any "
      "thread count.");
}

void def_filtered_grid(py::module_& m) {
  m.def(
      "filtered_grid",
      [](const crandall::Plan& plan) {
        if (!plan.options().filtered())
          throw std::invalid_argument("plan: filtered_grid needs excitation 'filtered'");
        std::vector<double> lengths, noises;
        for (const crandall::Segment& seg : plan.segments())
          for (std::uint64_t j = 0; j < seg.steps; ++j) {
            lengths.push_back(seg.step);
            noises.push_back(seg.noise);
          }
        std::vector<double> start(static_cast<std::size_t>(plan.filter()->filter.n));
        for (std::size_t i = 0; i < start.size(); ++i) start[i] = plan.filter()->start[i];
        return py::make_tuple(py::array_t<double>(static_cast<py::ssize_t>(lengths.size()), lengths.data()),
                              py::array_t<double>(static_cast<py::ssize_t>(noises.size()), noises.data()),
                              py::array_t<double>(static_cast<py::ssize_t>(start.size()), start.data()));
      },
      py::arg("plan"),
      "(lengths, noises, z0) of a filtered plan's walked grid: every fine step's length and "
      "intensity in time order, and the filter's start state.");
  m.def(
      "ground_feature_means",
      [](const crandall::Plan& plan) {
        const std::vector<double> v = crandall::ground_feature_means(plan);
        py::array_t<double> out({static_cast<py::ssize_t>(v.size() / crandall::kGroundFeatures),
                                 static_cast<py::ssize_t>(crandall::kGroundFeatures)});
        std::copy(v.begin(), v.end(), out.mutable_data());
        return out;
      },
      py::arg("plan"),
      "The exact means of a filtered plan's ground features (filtered.hpp), one row per output "
      "time and one for the stop (the last), GROUND_FEATURES columns: run_samples' control sums "
      "on a filtered plan are these features minus this row.");
  m.attr("GROUND_FEATURES") = crandall::kGroundFeatures;
  m.attr("BODY_CONTROLS") = crandall::kBodyControls;
  m.attr("BODY_PRODUCTS") = crandall::kBodyProducts;
  m.attr("BODY_SECOND_ORDER") = crandall::kBodySecondOrder;
  m.def("set_event_margin", &crandall::set_event_margin, py::arg("margin"),
        "Sets the multiple of an interval's a_g spread within which a filtered walk takes an "
        "event as possible (filtered.hpp, kEventMargin) for the process; returns the previous "
        "value. A diagnostic: results at other margins are not the documented ones.");
}

void def_tail_grid(py::module_& m) {
  m.def(
      "tail_grid",
      [](const crandall::Plan& plan, double dt, bool coarse, double max_steps) {
        if (plan.options().filtered())
          throw std::invalid_argument("plan: tail_grid needs a white-noise plan (filtered_grid "
                                      "is a filtered plan's)");
        const crandall::TailGrid grid = crandall::tail_grid(plan, dt, coarse, max_steps);
        auto array = [](const std::vector<double>& v) {
          return py::array_t<double>(static_cast<py::ssize_t>(v.size()), v.data());
        };
        return py::make_tuple(array(grid.lengths), array(grid.noises), array(grid.starts));
      },
      py::arg("plan"), py::arg("dt"), py::arg("coarse") = false, py::arg("max_steps") = 1e7,
      "(lengths, noises, starts) of a tail run's grid on a white-noise plan (plan.hpp "
      "tail_grid): each segment of the plan cut into max(1, ceil(length / dt - 1e-9)) equal "
      "steps (one without noise or when `coarse`). ValueError starting with 'dt:' past "
      "`max_steps` steps in a segment.");

  py::tuple split_quantities(crandall::kSplitQuantityNames.size());
  for (std::size_t i = 0; i < crandall::kSplitQuantityNames.size(); ++i)
    split_quantities[i] = py::str(crandall::kSplitQuantityNames[i]);
  m.attr("SPLIT_QUANTITIES") = split_quantities;
}

void def_split_parents(py::module_& m) {
  m.def(
      "split_parents",
      [](std::uint64_t key, std::uint64_t replica, std::uint64_t iteration,
         std::uint64_t survivors, std::size_t count) {
        py::array_t<std::int64_t> out(static_cast<py::ssize_t>(count));
        crandall::split_parents(key, replica, iteration, survivors, count, out.mutable_data());
        return out;
      },
      py::arg("key"), py::arg("replica"), py::arg("iteration"), py::arg("survivors"),
      py::arg("count"),
      "The parents of one splitting iteration's `count` clones: indices uniform on "
      "[0, survivors), drawn from Philox keyed by (key, replica, iteration) (split.hpp).");
}

void def_split_replica(py::module_& m) {
  m.def(
      "split_replica",
      [](Doubles lengths, Doubles noises, Doubles drifts, std::uint64_t key,
         std::vector<std::uint64_t> replicas, std::size_t particles, std::size_t kill,
         std::int64_t max_iterations, py::object deadline, double v0, double u0,
         std::size_t first, Doubles levels, Doubles thresholds, int quantity, double drift,
         double horizon, double coast, double mass, Doubles remaining, bool uncoast,
         py::object top, py::object normaliser, int threads) {
        const auto steps = static_cast<std::size_t>(lengths.size());
        if (noises.size() != lengths.size() || drifts.size() != lengths.size())
          throw std::invalid_argument("lengths, noises and drifts must have one value per step");
        if (steps == 0) throw std::invalid_argument("lengths: the grid has no step");
        if (static_cast<std::size_t>(remaining.size()) != steps + 1)
          throw std::invalid_argument("remaining must have steps + 1 values");
        if (levels.size() != thresholds.size() || levels.size() == 0)
          throw std::invalid_argument("levels and thresholds must have the same (> 0) length");
        if (quantity < 0 || quantity >= static_cast<int>(crandall::kSplitQuantityNames.size()))
          throw std::invalid_argument("quantity must be an index of SPLIT_QUANTITIES, got " +
                                      std::to_string(quantity));
        if (!(drift > 0.0)) throw std::invalid_argument("drift must be > 0");
        crandall::BranchGrid grid{lengths.data(), noises.data(), drifts.data(), steps};
        crandall::SplitScore score;
        score.quantity = static_cast<crandall::SplitQuantity>(quantity);
        score.drift = drift;
        score.horizon = horizon;
        score.coast = coast;
        score.mass = mass;
        score.remaining = remaining.data();
        score.uncoast = uncoast;
        std::vector<Doubles> keep;
        if (top.is_none() != normaliser.is_none())
          throw std::invalid_argument("top and normaliser: give both or neither");
        if (!top.is_none()) {
          score.normalised = true;
          score.top = top.cast<double>();
          auto t = normaliser.cast<py::tuple>();
          if (t.size() != 8)
            throw std::invalid_argument("normaliser must be (points, cum0, cum1, cum2, "
                                        "stationary, step, floor2, scale)");
          for (int j = 0; j < 6; ++j) {
            keep.push_back(Doubles::ensure(t[static_cast<std::size_t>(j)]));
            if (!keep.back() || keep.back().ndim() != 1 ||
                static_cast<std::size_t>(keep.back().size()) != steps + 1)
              throw std::invalid_argument("normaliser: its arrays must have steps + 1 values");
          }
          score.points = keep[0].data();
          score.cum0 = keep[1].data();
          score.cum1 = keep[2].data();
          score.cum2 = keep[3].data();
          score.stationary = keep[4].data();
          score.step = keep[5].data();
          score.floor2 = t[6].cast<double>();
          score.scale = t[7].cast<double>();
        }
        crandall::SplitRun run;
        run.particles = particles;
        run.kill = kill;
        run.key = key;
        if (replicas.empty()) throw std::invalid_argument("replicas: give at least one");
        run.replica = replicas.front();
        run.max_iterations = max_iterations;
        run.has_deadline = !deadline.is_none();
        if (run.has_deadline) run.deadline = deadline.cast<double>();
        run.v0 = v0;
        run.u0 = u0;
        run.first = first;
        run.levels = levels.data();
        run.thresholds = thresholds.data();
        run.level_count = static_cast<std::size_t>(levels.size());
        run.threads = threads;
        run.cancelled = bindings::python_cancel_check();
        std::vector<crandall::SplitOutcome> outs;
        try {
          outs = bindings::without_gil([&] {
            return crandall::split_replicas(grid, score, run, replicas.data(), replicas.size());
          });
        } catch (const crandall::Cancelled&) {
          // The KeyboardInterrupt (or a signal handler's exception) set by PyErr_CheckSignals.
          if (PyErr_Occurred()) throw py::error_already_set();
          throw std::runtime_error("run cancelled: the interpreter is exiting");
        }
        py::list result;
        for (const auto& out : outs) {
          py::array_t<double> estimates(static_cast<py::ssize_t>(out.estimates.size()));
          std::copy(out.estimates.begin(), out.estimates.end(), estimates.mutable_data());
          result.append(py::make_tuple(estimates, out.iterations, out.steps, out.log_weight,
                                       out.extinct, out.timed_out));
        }
        return result;
      },
      py::arg("lengths"), py::arg("noises"), py::arg("drifts"), py::arg("key"),
      py::arg("replicas"), py::arg("particles"), py::arg("kill"), py::arg("max_iterations"),
      py::arg("deadline"), py::arg("v0"), py::arg("u0"), py::arg("first"), py::arg("levels"),
      py::arg("thresholds"), py::arg("quantity"), py::arg("drift"), py::arg("horizon"),
      py::arg("coast"), py::arg("mass"), py::arg("remaining"), py::arg("uncoast"),
      py::arg("top"), py::arg("normaliser"), py::arg("threads") = 1,
      "Replicas of adaptive multilevel splitting on a white-noise grid, in step (split.hpp's "
      "split_replicas: each the bits it has alone): a list, per replica, of (estimates, "
      "iterations, steps, log_weight, extinct, timed_out). The GIL is released.");
}

}  // namespace

void register_branch(py::module_& m) {
  def_extend_paths(m);
  def_extend_filtered_paths(m);
  def_filtered_grid(m);
  def_tail_grid(m);
  def_split_parents(m);
  def_split_replica(m);
}
