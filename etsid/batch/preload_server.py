"""Imported first by the local pool's fork server: the server dies with the batch process
that started it (:mod:`etsid.batch.lifeline`), and its workers with it."""

from __future__ import annotations

import os

from etsid.batch.lifeline import PARENT_ENV, die_with_parent

if os.environ.get(PARENT_ENV, "").isdigit():
    die_with_parent(int(os.environ[PARENT_ENV]))
