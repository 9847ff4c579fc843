#!/bin/sh
# Checks that the core's results are the same bits on x86-64 and aarch64: links
# bench/core_bits.cpp (every double of a few runs: the white-noise kernel with the exact method,
# its stop and peaks, a Richardson run on pieces, per-path values with the control sums;
# splitting's path continuation; Kanai-Tajimi and Clough-Penzien filtered runs with the stop;
# Newmark's block on a record, exact and pySLAMMER's) against the core library as CMakeLists.txt
# builds it (its flags: -O3 -ffp-contract=off -fno-trapping-math -fno-math-errno), natively and
# with the aarch64 cross compiler (bench/aarch64.cmake: the baseline kernel variant only), runs
# the second under qemu-user, and compares the dumps line by line. Natively it runs the best
# kernel variant of the CPU and the baseline one (the variants' claim, on the same machine), and
# the x86-64 build under qemu-x86_64 on a CPU without AVX or FMA (Nehalem), where glibc's exp,
# log1p and hypot take their code without FMA. The C library's functions the core called are
# checked too (one hash of a million results each; splitting's log1p(-k / n) value by value),
# and the core's own exp, log1p, log and log erfc that replace them (bench/detfunc_bits.cpp).
# A third build, for aarch64, appends GCC's default -ffp-contract=fast to every compilation of
# the core (and builds the driver at -O3 without -ffp-contract=off): what the results would be
# if the build let GCC fuse a * b + c into fused multiply-adds, which aarch64 has and baseline
# x86-64 has not.
# Needs (Debian): apt-get install g++-aarch64-linux-gnu qemu-user libeigen3-dev.
# Not part of CI: three builds of the core (some 10 minutes on two cores), the runs a minute
# under qemu, `units` 3 more.
# With a second argument `units`, it then says which of the core's translation units' contraction
# changes which numbers: the aarch64 library with one unit's object taken from the contracted
# build at a time (a unit holds the inline functions of the headers it uses, and the linker keeps
# one copy of each, so a unit may change runs that are not its own).
# Usage: sh bench/core_bits.sh [OUTDIR [units]]   (from the repository's root; default
# /tmp/crandall-aarch64, shared with bench/core_tests_aarch64.sh's aarch64 build)
set -eu
out=${1:-/tmp/crandall-aarch64}
units=${2:-}
mkdir -p "$out"
printf '#!/bin/sh\nexec "$@" -ffp-contract=fast\n' > "$out/contract.sh"
chmod +x "$out/contract.sh"
cross="-DCMAKE_TOOLCHAIN_FILE=$(pwd)/bench/aarch64.cmake"
cmake -S . -B "$out/x86_64-build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake -S . -B "$out/core-build" -G Ninja -DCMAKE_BUILD_TYPE=Release $cross >/dev/null
cmake -S . -B "$out/contract-build" -G Ninja -DCMAKE_BUILD_TYPE=Release $cross \
  -DCMAKE_CXX_COMPILER_LAUNCHER="$out/contract.sh" >/dev/null
for b in x86_64-build core-build contract-build; do cmake --build "$out/$b" --target crandall_core -j2; done
inc="-Icpp/include -Ithird_party/Random123/include -I/usr/include/eigen3"
flags="-std=c++17 -O2 -fopenmp -ffp-contract=off -fno-trapping-math -fno-math-errno $inc"
g++ $flags bench/core_bits.cpp "$out/x86_64-build/libcrandall_core.a" -o "$out/core_bits_x86_64"
aarch64-linux-gnu-g++ $flags bench/core_bits.cpp "$out/core-build/libcrandall_core.a" -o "$out/core_bits_aarch64"
aarch64-linux-gnu-g++ -std=c++17 -O3 -fopenmp $inc bench/core_bits.cpp \
  "$out/contract-build/libcrandall_core.a" -o "$out/core_bits_aarch64_contract"
"$out/core_bits_x86_64" > "$out/core_bits_x86_64.txt"
"$out/core_bits_x86_64" baseline > "$out/core_bits_x86_64_baseline.txt"
qemu-x86_64 -cpu Nehalem "$out/core_bits_x86_64" > "$out/core_bits_x86_64_nehalem.txt"
qemu-aarch64 -L /usr/aarch64-linux-gnu "$out/core_bits_aarch64" > "$out/core_bits_aarch64.txt"
qemu-aarch64 -L /usr/aarch64-linux-gnu "$out/core_bits_aarch64_contract" > "$out/core_bits_aarch64_contract.txt"
echo "$(grep -c '\[' "$out/core_bits_x86_64.txt") doubles, $(grep -c hash "$out/core_bits_x86_64.txt") hashes"
# Lines (a double or a hash each) whose bits differ from x86-64's, then the runs they belong to.
compare() {
  awk -v name="$2" 'NR == FNR { a[FNR] = $0; next }
    { if (a[FNR] != $0) { n++; split($0, f, "["); runs[f[1]]++ } }
    END { printf "%s: %d lines with other bits\n", name, n;
          for (r in runs) printf "  %s: %d\n", r, runs[r] }' "$out/core_bits_x86_64.txt" "$1"
}
compare "$out/core_bits_x86_64_baseline.txt" "x86-64 baseline variant"
compare "$out/core_bits_x86_64_nehalem.txt" "x86-64 on qemu's Nehalem (no AVX, no FMA)"
compare "$out/core_bits_aarch64.txt" "aarch64"
compare "$out/core_bits_aarch64_contract.txt" "aarch64 -ffp-contract=fast"
# The C library's exp, log1p and hypot at a million arguments (bench/libm_bits.cpp): how many
# results have other bits than x86-64's, per function.
g++ -O2 -ffp-contract=off -fno-math-errno bench/libm_bits.cpp -o "$out/libm_bits_x86_64"
aarch64-linux-gnu-g++ -O2 -ffp-contract=off -fno-math-errno bench/libm_bits.cpp -o "$out/libm_bits_aarch64"
"$out/libm_bits_x86_64" > "$out/libm_x86_64.bin"
qemu-x86_64 -cpu Nehalem "$out/libm_bits_x86_64" > "$out/libm_nehalem.bin"
qemu-aarch64 -L /usr/aarch64-linux-gnu "$out/libm_bits_aarch64" > "$out/libm_aarch64.bin"
for p in nehalem aarch64; do
  cmp -l "$out/libm_x86_64.bin" "$out/libm_$p.bin" | awk -v p="$p" '
    { r = int(($1 - 1) / 8); if (r != last) { n[r % 3]++; last = r } }
    END { printf "libm on %s: other bits for %d exp, %d log1p, %d hypot of 1000000\n", p, n[0], n[1], n[2] }' || true
done
# The core's own exp, log1p, log and log erfc (cpp/src/detfunc.cpp, the tail estimators'
# weights) at a million arguments each (bench/detfunc_bits.cpp): they must have the same bits
# everywhere, whatever the target's instruction set (-march=native lets GCC use FMA, which
# -ffp-contract=off keeps out of a * b + c).
detflags="-O2 -ffp-contract=off -fno-math-errno -Icpp/include"
g++ $detflags bench/detfunc_bits.cpp cpp/src/detfunc.cpp -o "$out/detfunc_bits_x86_64"
g++ $detflags -O3 -march=native bench/detfunc_bits.cpp cpp/src/detfunc.cpp -o "$out/detfunc_bits_native"
aarch64-linux-gnu-g++ $detflags bench/detfunc_bits.cpp cpp/src/detfunc.cpp -o "$out/detfunc_bits_aarch64"
"$out/detfunc_bits_x86_64" > "$out/detfunc_x86_64.bin"
"$out/detfunc_bits_native" > "$out/detfunc_native.bin"
qemu-x86_64 -cpu Nehalem "$out/detfunc_bits_x86_64" > "$out/detfunc_nehalem.bin"
qemu-aarch64 -L /usr/aarch64-linux-gnu "$out/detfunc_bits_aarch64" > "$out/detfunc_aarch64.bin"
for p in native nehalem aarch64; do
  cmp -l "$out/detfunc_x86_64.bin" "$out/detfunc_$p.bin" | awk -v p="$p" '
    { r = int(($1 - 1) / 8); if (r != last) { n[r % 4]++; last = r } }
    END { printf "detfunc on %s: other bits for %d exp, %d log1p, %d log, %d log_erfc of 1000000\n", p, n[0], n[1], n[2], n[3] }' || true
done
[ "$units" = units ] || exit 0
objects="$out/contract-build/CMakeFiles/crandall_core.dir/cpp/src"
aarch64-linux-gnu-g++ $flags -c bench/core_bits.cpp -o "$out/core_bits_aarch64.o"
for o in $(aarch64-linux-gnu-ar t "$out/core-build/libcrandall_core.a"); do
  cmp -s "$objects/$o" "$out/core-build/CMakeFiles/crandall_core.dir/cpp/src/$o" && continue
  mkdir -p "$out/unit"
  cp "$out/core-build/libcrandall_core.a" "$out/unit/lib.a"
  cp "$objects/$o" "$out/unit/$o"
  aarch64-linux-gnu-ar r "$out/unit/lib.a" "$out/unit/$o"
  aarch64-linux-gnu-g++ -fopenmp "$out/core_bits_aarch64.o" "$out/unit/lib.a" -o "$out/unit/core_bits"
  qemu-aarch64 -L /usr/aarch64-linux-gnu "$out/unit/core_bits" > "$out/unit/$o.txt" 2>/dev/null
  compare "$out/unit/$o.txt" "aarch64, $o alone contracted"
done
