// Prints every double of the filtered excitation's plan (filter.cpp's make_filter_model: the
// skeleton's transitions, the noise tree's levels, spreads and midpoint rows, the decay bound)
// as hexadecimal bits, for a Kanai-Tajimi and a Clough-Penzien filter at a few steps.
// bench/filter_plan_bits.sh builds it for x86-64 and for aarch64 (run under qemu) and compares
// the two outputs bit by bit (docs/filtered.md, "The same doubles on every CPU").
#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "crandall/filter.hpp"
#include "crandall/plan.hpp"

// filter.cpp's only use of plan.cpp is a validation message: the driver does not link plan.cpp.
const char* crandall::method_name(crandall::Method) { return "exact"; }

namespace {

void print(const std::string& label, const std::vector<double>& v) {
  for (std::size_t i = 0; i < v.size(); ++i) {
    std::uint64_t bits;
    std::memcpy(&bits, &v[i], sizeof bits);
    std::printf("%s[%zu] %016" PRIx64 " %.17g\n", label.c_str(), i, bits, v[i]);
  }
}

void print(const std::string& label, double x) { print(label, std::vector<double>{x}); }

void dump(const std::string& name, const crandall::LinearFilter& f, const std::vector<double>& steps) {
  crandall::Options o;
  o.excitation = crandall::Excitation::filtered;
  o.filter_a = f.a;
  o.filter_b = f.b;
  o.filter_c = f.c;
  o.stop = true;
  o.drift = 1.0;
  const auto model = crandall::make_filter_model(o, steps, steps.back());
  for (std::size_t k = 0; k < model->tables.size(); ++k) {
    const crandall::StepTable& t = model->tables[k];
    const std::string p = name + " h=" + std::to_string(t.step) + " ";
    print(p + "phi", t.skeleton.phi);
    print(p + "q", t.skeleton.q);
    print(p + "root", t.skeleton.root);
    for (std::size_t i = 0; i < t.levels.size(); ++i) {
      const std::string l = p + "level" + std::to_string(i) + " ";
      print(l + "phi", t.levels[i].phi);
      print(l + "root", t.levels[i].root);
      print(l + "split", t.levels[i].split);
      print(l + "spread", t.levels[i].spread);
    }
    print(p + "spread_fine", t.spread_fine);
    print(p + "spread_coarse", t.spread_coarse);
    print(p + "mid_z", t.mid_z);
    print(p + "mid_xi", t.mid_xi);
    // transition()'s own root (psd_root of Q; the plan replaces it by the tree's) and the
    // quadrature root at the step
    print(p + "psd_root", crandall::transition(f, t.step).root);
    print(p + "quadrature_root", crandall::quadrature_root(f, t.step));
  }
  print(name + " c_a2", model->c_a2);
  print(name + " bound.p", model->bound.p);
  print(name + " bound.gain", model->bound.gain);
  print(name + " bound.rate", model->bound.rate);
}

}  // namespace

int main() {
  const std::vector<double> steps = {0.5, 0.15625, 0.02, 1e-3};
  dump("kanai_tajimi(2,0.6)", crandall::kanai_tajimi(2.0, 0.6), steps);
  dump("kanai_tajimi(0.5,0.6)", crandall::kanai_tajimi(0.5, 0.6), steps);
  dump("clough_penzien(0.5,0.6,0.1,0.6)", crandall::clough_penzien(0.5, 0.6, 0.1, 0.6), steps);
  dump("clough_penzien(15.6,0.6,1.6,0.6)", crandall::clough_penzien(15.6, 0.6, 1.6, 0.6), steps);
  return 0;
}
