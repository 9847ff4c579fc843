#include "crandall/dispatch.hpp"

#include <atomic>
#include <cstdlib>
#include <mutex>
#include <stdexcept>

#include "crandall/variant.hpp"

#if CRANDALL_X86
#include <cpuid.h>
#endif

namespace crandall {

// Each variant translation unit defines its table in its own namespace.
namespace baseline { const KernelTable& kernel_table(); }
#if CRANDALL_X86
namespace avx2 { const KernelTable& kernel_table(); }
namespace avx512 { const KernelTable& kernel_table(); }
#endif

namespace {

#if CRANDALL_X86
struct CpuLevels {
  bool v3 = false;  // x86-64-v3 features, with the OS saving the AVX registers
  bool v4 = false;  // x86-64-v4 features, with the OS saving the AVX-512 registers too
};

// CPUID says what the processor has; XGETBV says which register state the operating system
// saves on a context switch. Both are needed (a CPU with AVX-512 under an OS, a hypervisor or
// an emulator that does not enable it must not run AVX-512 code), so the check is done here
// explicitly rather than trusting a compiler builtin's version-dependent behaviour.
CpuLevels detect() {
  CpuLevels out;
  unsigned a, b, c, d;
  if (!__get_cpuid(1, &a, &b, &c, &d)) return out;
  const unsigned c1 = c;
  const bool osxsave = c1 & (1u << 27);
  const bool v2 = (c1 & (1u << 0)) && (c1 & (1u << 9)) && (c1 & (1u << 19)) &&
                  (c1 & (1u << 20)) && (c1 & (1u << 23)) && (c1 & (1u << 13));  // sse3 ssse3 sse4.1 sse4.2 popcnt cx16
  const bool v3_1 = (c1 & (1u << 28)) && (c1 & (1u << 12)) && (c1 & (1u << 29)) &&
                    (c1 & (1u << 22));  // avx fma f16c movbe
  if (!osxsave || !v2 || !v3_1) return out;
  unsigned xlo;  // the low half of XCR0 holds every bit read here; edx gets the high half
  __asm__ volatile("xgetbv" : "=a"(xlo) : "c"(0) : "edx");
  const bool os_avx = (xlo & 0x6u) == 0x6u;       // SSE and AVX state
  const bool os_avx512 = (xlo & 0xE6u) == 0xE6u;  // + opmask, upper ZMM0-15, ZMM16-31
  if (__get_cpuid_max(0, nullptr) < 7) return out;
  __cpuid_count(7, 0, a, b, c, d);
  const unsigned b7 = b;
  const bool v3_7 = (b7 & (1u << 5)) && (b7 & (1u << 3)) && (b7 & (1u << 8));  // avx2 bmi1 bmi2
  bool lzcnt = false;
  if (__get_cpuid(0x80000001u, &a, &b, &c, &d)) lzcnt = c & (1u << 5);
  out.v3 = os_avx && v3_7 && lzcnt;
  const bool v4_7 = (b7 & (1u << 16)) && (b7 & (1u << 17)) && (b7 & (1u << 28)) &&
                    (b7 & (1u << 30)) && (b7 & (1u << 31));  // avx512 f dq cd bw vl
  out.v4 = out.v3 && os_avx512 && v4_7;
  return out;
}

const CpuLevels& cpu() {
  static const CpuLevels levels = detect();
  return levels;
}
#endif

std::atomic<const KernelTable*> g_active{nullptr};
std::once_flag g_init;

const KernelTable* find(const std::string& name) {
  for (const KernelTable* k : compiled_kernels())
    if (name == k->name) return k;
  return nullptr;
}

std::string names(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

}  // namespace

const std::vector<const KernelTable*>& compiled_kernels() {
  static const std::vector<const KernelTable*> all = {
      &baseline::kernel_table(),
#if CRANDALL_X86
      &avx2::kernel_table(),
      &avx512::kernel_table(),
#endif
  };
  return all;
}

bool kernel_supported(const KernelTable& k) {
  const std::string name = k.name;
  if (name == "baseline") return true;
#if CRANDALL_X86
  if (name == "avx2") return cpu().v3;
  if (name == "avx512") return cpu().v4;
#endif
  return false;
}

std::vector<std::string> available_kernels() {
  std::vector<std::string> out;
  for (const KernelTable* k : compiled_kernels())
    if (kernel_supported(*k)) out.emplace_back(k->name);
  return out;
}

void select_kernel(const std::string& name) {
  const KernelTable* k = find(name);
  if (!k) {
    std::string known;
    for (const KernelTable* c : compiled_kernels()) known += (known.empty() ? "" : ", ") + std::string(c->name);
    throw std::invalid_argument("CRANDALL_ISA='" + name + "' is not a kernel variant of this build (one of: " +
                                known + ")");
  }
  if (!kernel_supported(*k))
    throw std::invalid_argument("CRANDALL_ISA='" + name +
                                "' is not supported by this CPU or operating system (supported here: " +
                                names(available_kernels()) + ")");
  g_active.store(k);
}

std::string kernel_from_environment() {
  const char* env = std::getenv("CRANDALL_ISA");
  if (env && *env) return env;
  return available_kernels().back();
}

const KernelTable& active_kernel() {
  std::call_once(g_init, [] {
    if (!g_active.load()) select_kernel(kernel_from_environment());
  });
  return *g_active.load();
}

}  // namespace crandall
