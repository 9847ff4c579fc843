"""What a run may use of this machine, and what it shows while it runs: the memory a process
may still allocate (free memory, rlimits, cgroup), and the progress bar. Shared by fixed-step
runs and runs to an accuracy (one place for each)."""

from __future__ import annotations

import os
import sys
from typing import Optional

from .errors import ParameterError


def _read_int(path: str) -> Optional[int]:
    try:
        with open(path) as f:
            text = f.read().strip()
    except OSError:
        return None
    try:
        return int(text)
    except ValueError:  # "max": no limit
        return None


def _cgroup_available(root: str = "/sys/fs/cgroup") -> Optional[int]:
    """Bytes the memory cgroup of this process may still allocate (None: no limit found)."""
    found = []
    # cgroup v2: this process's group (from /proc/self/cgroup) and, in a container whose
    # cgroup namespace hides it, the root of the mount.
    groups = [""]
    try:
        with open("/proc/self/cgroup") as f:
            for line in f:
                parts = line.strip().split(":", 2)
                if len(parts) == 3 and parts[0] == "0":
                    groups.insert(0, parts[2].lstrip("/"))
    except OSError:
        pass
    for group in groups:
        base = os.path.join(root, group) if group else root
        limit = _read_int(os.path.join(base, "memory.max"))
        used = _read_int(os.path.join(base, "memory.current"))
        if limit is not None and used is not None:
            found.append(limit - used)
    # cgroup v1.
    limit = _read_int(os.path.join(root, "memory", "memory.limit_in_bytes"))
    used = _read_int(os.path.join(root, "memory", "memory.usage_in_bytes"))
    if limit is not None and used is not None and limit < 1 << 60:  # 2^63-ish: unlimited
        found.append(limit - used)
    return min(found) if found else None


def _process_sizes() -> dict:
    """VmSize and VmData of this process, bytes (empty where /proc is missing)."""
    out = {}
    try:
        with open("/proc/self/status") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key in ("VmSize", "VmData"):
                    out[key] = int(value.split()[0]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return out


def available_memory() -> int:
    """Bytes this process can still allocate: the least of free RAM, its address-space and
    data rlimits (less what it uses) and its memory cgroup's limit (less what it uses)."""
    have = []
    try:
        have.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        pass
    try:
        import resource
    except ImportError:  # pragma: no cover - not on POSIX
        resource = None
    if resource is not None:
        sizes = _process_sizes()
        for name, used in (("RLIMIT_AS", "VmSize"), ("RLIMIT_DATA", "VmData")):
            limit = getattr(resource, name, None)
            if limit is None:
                continue
            soft, _ = resource.getrlimit(limit)
            if soft != resource.RLIM_INFINITY:
                have.append(soft - sizes.get(used, 0))
    cgroup = _cgroup_available()
    if cgroup is not None:
        have.append(cgroup)
    return max(0, min(have)) if have else 1 << 62


def _interactive() -> bool:
    """A person is watching: stderr is a terminal or this is a notebook's kernel (Jupyter,
    whose output is no terminal), and not CI or a test run."""
    if os.environ.get("CI") or "PYTEST_CURRENT_TEST" in os.environ:
        return False
    if "ipykernel.zmqshell" in sys.modules:  # the test tqdm.auto makes for a notebook
        return True
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # closed or replaced stderr
        return False


def progress_bar(progress, *, total: Optional[int], initial: int = 0):
    """A tqdm bar, or None: ``progress`` True, False or None (only where a person watches and
    the run lasts more than two seconds)."""
    if progress is None:
        progress, delay = _interactive(), 2.0  # only runs longer than a couple of seconds
    else:
        if not isinstance(progress, bool):
            raise ParameterError("progress", f"progress must be True, False or None, got {progress!r}")
        delay = 0.0
    if not progress:
        return None
    # tqdm.auto: a widget in a notebook, text on a terminal.
    from tqdm.auto import tqdm

    if total is None:  # a run to an accuracy: no path count known in advance
        return tqdm(total=None, delay=delay, desc="crandall", leave=False,
                    bar_format="{desc}{postfix} [{elapsed}]", dynamic_ncols=True)
    return tqdm(total=total, initial=initial, unit="path", unit_scale=True, delay=delay,
                desc="crandall", leave=False, dynamic_ncols=True)
