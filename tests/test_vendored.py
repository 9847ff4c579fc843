"""The build takes Random123 from third_party/ (no system package needed): CMakeLists.txt
points the core at it by default, and the copy is complete (philox.h compiles against it
alone, every header it includes resolved inside third_party/)."""

import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
VENDORED = ROOT / "third_party" / "Random123" / "include"


def test_cmake_uses_the_vendored_headers_by_default():
    text = (ROOT / "CMakeLists.txt").read_text()
    assert 'option(CRANDALL_SYSTEM_RANDOM123 "use the system\'s Random123 headers instead of third_party/" OFF)' in text
    assert "set(RANDOM123_INCLUDE_DIR ${CMAKE_CURRENT_SOURCE_DIR}/third_party/Random123/include)" in text
    assert (VENDORED.parent / "LICENSE").read_text().startswith("Copyright 2010-2021, D. E. Shaw Research.")


@pytest.mark.skipif(shutil.which("g++") is None, reason="needs g++")
def test_philox_compiles_from_the_vendored_copy_alone(tmp_path):
    src = tmp_path / "probe.cpp"
    src.write_text("#include <Random123/philox.h>\n"
                   "int main() { r123::Philox4x32 g; r123::Philox4x32::ctr_type c = {{0, 0, 0, 0}};\n"
                   "  r123::Philox4x32::key_type k = {{0, 0}}; return static_cast<int>(g(c, k)[0] & 0); }\n")
    # -H lists every header opened: Random123's must all come from third_party/.
    proc = subprocess.run(["g++", "-std=c++17", "-fsyntax-only", "-H", "-I", str(VENDORED), str(src)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    opened = [line.lstrip(". ").strip() for line in proc.stderr.splitlines() if "Random123" in line]
    assert opened and all(str(VENDORED) in p for p in opened), opened
