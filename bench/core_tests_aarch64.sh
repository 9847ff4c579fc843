#!/bin/sh
# Builds the core's C++ unit tests (cpp/tests, GoogleTest) for aarch64 with Debian's cross
# compiler and runs them under qemu-user: the whole core (the white-noise kernel's portable
# variant, the filtered walker, the records integrator, splitting, the plan, ...) linked and
# run on another architecture, not only compiled. GoogleTest is built for aarch64 first from
# the sources libgtest-dev ships (/usr/src/googletest). The toolchain (bench/aarch64.cmake)
# makes CMakeLists.txt build the baseline kernel variant only, as on any non-x86 host.
# Needs (Debian): apt-get install g++-aarch64-linux-gnu qemu-user libeigen3-dev libgtest-dev.
# Not part of CI: about 5 minutes on two cores (GoogleTest, the core and the tests built, the
# tests run under qemu in 2 of them).
# Usage: sh bench/core_tests_aarch64.sh [OUTDIR]   (from the repository's root; default
# /tmp/crandall-aarch64). Extra arguments go to ctest (-R Filtered, -j2, ...).
set -eu
out=${1:-/tmp/crandall-aarch64}
[ $# -gt 0 ] && shift
src=$(pwd)
toolchain="$src/bench/aarch64.cmake"
cmake -Wno-deprecated -S /usr/src/googletest -B "$out/gtest-build" -G Ninja -DCMAKE_TOOLCHAIN_FILE="$toolchain" \
  -DCMAKE_BUILD_TYPE=Release -DBUILD_GMOCK=OFF -DCMAKE_INSTALL_PREFIX="$out/gtest" >/dev/null
cmake --build "$out/gtest-build" -j2
cmake --install "$out/gtest-build" >/dev/null
cmake -S . -B "$out/core-build" -G Ninja -DCMAKE_TOOLCHAIN_FILE="$toolchain" -DCRANDALL_BUILD_TESTS=ON \
  -DCRANDALL_WERROR=ON -DCMAKE_BUILD_TYPE=Release -DGTest_DIR="$out/gtest/lib/cmake/GTest" >/dev/null
cmake --build "$out/core-build" -j2
cd "$out/core-build" && ctest --output-on-failure "$@"
