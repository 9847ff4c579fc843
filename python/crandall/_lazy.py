"""A module loaded on first use: ``import crandall`` does not pay for the analytic layer
(scipy) until a scene asks for automatic histogram scales or a closed form."""

from __future__ import annotations

import importlib
import threading
from types import ModuleType
from typing import Any, Optional

__all__ = ["lazy_module"]


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
