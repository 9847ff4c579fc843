"""Modules loaded on first use: ``import crandall`` does not pay for the analytic layer or the
envelopes (scipy) until a scene asks for automatic histogram scales, a closed form or an
envelope, or the user reads ``crandall.analytic`` or ``crandall.envelopes``."""

from __future__ import annotations

import importlib
import threading
from types import ModuleType
from typing import Any, Callable, Iterable, Optional

__all__ = ["lazy_module", "lazy_submodules"]


class _LazyModule(ModuleType):
    """Stands for the module ``name``: the first attribute read imports it (once, under a
    lock, so threads that ask together import it once), every read is the module's."""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self._lock = threading.Lock()
        self._module: Optional[ModuleType] = None

    def __getattr__(self, attr: str) -> Any:
        module = self._module
        if module is None:
            with self._lock:
                if self._module is None:
                    self._module = importlib.import_module(self.__name__)
                module = self._module
        return getattr(module, attr)


def lazy_module(name: str) -> ModuleType:
    """A stand-in for the module ``name`` (absolute), imported when one of its attributes is
    first read."""
    return _LazyModule(name)


def lazy_submodules(package: str, names: Iterable[str]) -> Callable[[str], Any]:
    """A package's module ``__getattr__`` (PEP 562) that imports its submodules ``names`` when
    first read as attributes (``crandall.envelopes.amin_ang(...)`` after a plain ``import
    crandall``). The attribute is the module itself (not a stand-in): the import system then
    binds it on the package, and ``from package import name`` gets the same module."""
    names = frozenset(names)

    def __getattr__(attr: str) -> Any:
        if attr in names:
            return importlib.import_module(f"{package}.{attr}")
        raise AttributeError(f"module {package!r} has no attribute {attr!r}")

    return __getattr__
