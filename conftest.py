"""Settings for the whole test suite (at the root: a tests/conftest.py clashes with the
sub-folders' conftest modules under --doctest-modules)."""

from __future__ import annotations

import os

# Progress lines appear when a step takes over 2 s, which depends on the machine's load:
# off, so tests of exact command output do not (tests/test_progress.py turns it on).
os.environ.setdefault("ETSID_PROGRESS", "off")
