# CMake toolchain file: cross-compile the core and its C++ tests for aarch64 (64-bit Arm Linux)
# with Debian's cross compiler, and run what is built under qemu-user. CMAKE_SYSTEM_PROCESSOR
# makes CMakeLists.txt build the portable kernel variant only (no AVX2 or AVX-512 units, no
# -mprefer-vector-width). Used by bench/core_tests_aarch64.sh and bench/core_bits.sh.
# Needs (Debian): apt-get install g++-aarch64-linux-gnu qemu-user libeigen3-dev libgtest-dev.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# The aarch64 libraries (libc, libstdc++, libgomp) live under the cross sysroot; qemu-user
# needs it as its prefix. CMake runs the test binary through it to list the tests (GoogleTest's
# gtest_discover_tests) and ctest runs every test through it.
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-aarch64 -L /usr/aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
# Packages: Eigen is header-only (its config in /usr/share/eigen3/cmake serves any
# architecture); GoogleTest is built for aarch64 from /usr/src/googletest and installed into a
# prefix passed as CMAKE_PREFIX_PATH, which BOTH lets CMake search outside the sysroot.
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
