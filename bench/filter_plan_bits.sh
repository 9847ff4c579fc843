#!/bin/sh
# Checks that the filtered excitation's plan doubles (cpp/src/filter.cpp, double-double algebra)
# are the same bits on x86-64 and aarch64: builds bench/filter_plan_bits.cpp natively and with
# the aarch64 cross compiler, runs the second under qemu-user, and compares the two dumps (every
# plan double of two Kanai-Tajimi and two Clough-Penzien filters at four steps, 33,628 numbers).
# The aarch64 build is also made with GCC's default -ffp-contract=fast at -O3: the arithmetic
# names every fused multiply-add itself, so contraction must change nothing.
# Needs (Debian): apt-get install g++-aarch64-linux-gnu qemu-user libeigen3-dev.
# Not part of CI (a cross build of filter.cpp takes minutes under qemu's compiler load).
# Usage: sh bench/filter_plan_bits.sh [OUTDIR]   (from the repository's root; default /tmp)
set -eu
out=${1:-/tmp}
flags="-std=c++17 -O2 -ffp-contract=off -fno-trapping-math -fno-math-errno -Icpp/include -I/usr/include/eigen3"
src="bench/filter_plan_bits.cpp cpp/src/filter.cpp"
g++ $flags $src -o "$out/plan_bits_x86_64"
aarch64-linux-gnu-g++ $flags $src -o "$out/plan_bits_aarch64"
aarch64-linux-gnu-g++ -std=c++17 -O3 -Icpp/include -I/usr/include/eigen3 $src -o "$out/plan_bits_aarch64_contract"
"$out/plan_bits_x86_64" > "$out/plan_bits_x86_64.txt"
qemu-aarch64 -L /usr/aarch64-linux-gnu "$out/plan_bits_aarch64" > "$out/plan_bits_aarch64.txt"
qemu-aarch64 -L /usr/aarch64-linux-gnu "$out/plan_bits_aarch64_contract" > "$out/plan_bits_aarch64_contract.txt"
echo "$(wc -l < "$out/plan_bits_x86_64.txt") plan doubles"
cmp "$out/plan_bits_x86_64.txt" "$out/plan_bits_aarch64.txt" && echo "aarch64: the same bits"
cmp "$out/plan_bits_x86_64.txt" "$out/plan_bits_aarch64_contract.txt" && echo "aarch64 -O3 -ffp-contract=fast: the same bits"
