"""etsid: learn a drone's rate dynamics from its flight logs with evolving Takagi-Sugeno models."""

from __future__ import annotations

from etsid.cachedir import use_user_cache

__version__ = "0.1.0"

use_user_cache()  # compiled numba kernels go to the user cache, never into site-packages
