"""Say so when numba compiles a kernel (a cold cache): the one step that can take a minute.

A kernel found in the cache (``etsid.cachedir``) loads in well under a second; one that is
not is compiled, which takes seconds to a minute per kernel on a slow machine, inside
whatever step first calls it (identify's structure choice, simulate's first flight second).
:func:`install` hooks numba's compile event (fired on a cache miss only, not on a cache
load): the first compile of the process prints one line at once, naming the cache folder;
while any compile runs, the current step (:mod:`etsid.progress`) says it is compiling, and
the step around it is said again afterwards. Nothing is said when progress is off.

The narrator is handed in (:func:`install`), so this module imports nothing of etsid and
:mod:`etsid.progress` can install it without an import cycle.
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol


class Narrator(Protocol):
    """What a compile note needs of :class:`etsid.progress.Narrator`."""

    def push(self, label: str, at_once: bool = False) -> None: ...

    def pop(self) -> None: ...


_state: dict[str, Any] = {"installed": False, "said": False, "depth": 0, "pushed": False,
                          "narrator": None, "enabled": lambda: False}
_lock = threading.Lock()


def cache_folder() -> str:
    """numba's cache folder in use, with the home folder written ``~``."""
    folder = os.environ.get("NUMBA_CACHE_DIR", "")
    home = str(Path.home())
    return "~" + folder[len(home):] if folder.startswith(home + os.sep) else folder


def kernel_name(data: Any) -> str:
    """``module.function`` of the dispatcher a compile event is about (``?`` if unknown)."""
    func = getattr((data or {}).get("dispatcher"), "py_func", None)
    if func is None:
        return "?"
    return f"{func.__module__.removeprefix('etsid.')}.{func.__name__}"


def on_compile_start(name: str) -> None:
    """An outermost compile of kernel ``name`` began: say it (at once the first time)."""
    with _lock:
        _state["depth"] += 1
        if _state["depth"] > 1 or not _state["enabled"]():
            return
        first = not _state["said"]
        _state["said"] = _state["pushed"] = True
    label = (f"compiling numba kernels ({name}); first run only, cached in {cache_folder()}")
    _state["narrator"].push(label, at_once=first)


def on_compile_end() -> None:
    """A compile ended; the outermost one gives the step around it back."""
    with _lock:
        _state["depth"] = max(0, _state["depth"] - 1)
        give_back = _state["depth"] == 0 and _state["pushed"]
        if give_back:
            _state["pushed"] = False
    if give_back:
        _state["narrator"].pop()


def install(narrator: Narrator, enabled: Callable[[], bool]) -> bool:
    """Listen to numba's compile events (once per process; only if numba is imported),
    telling ``narrator`` while ``enabled()`` is true.

    Returns True when the listener is in place.
    """
    _state["narrator"], _state["enabled"] = narrator, enabled
    if _state["installed"]:
        return True
    if "numba" not in sys.modules:
        return False
    from numba.core import event

    class _Listener(event.Listener):  # type: ignore[misc]
        def on_start(self, ev: Any) -> None:
            on_compile_start(kernel_name(ev.data))

        def on_end(self, ev: Any) -> None:
            on_compile_end()

    event.register("numba:compile", _Listener())
    _state["installed"] = True
    return True
