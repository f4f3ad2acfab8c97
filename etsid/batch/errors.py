"""The batch layer's error (kept beside the batch package; a candidate for etsid/errors.py)."""

from __future__ import annotations

from etsid.errors import EtsidError


class BatchError(EtsidError):
    """A batch cannot be set up or one log cannot be run: no inputs, an unreadable list
    file, a bad pairs CSV, a missing input, an unreachable scheduler."""
