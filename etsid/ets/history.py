"""What an eTS model records while learning: per-step structure, events, consequent snapshots."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

#: columns of :meth:`History.to_frame`
FRAME_COLUMNS = ("step", "n_rules", "potential", "focal_max", "focal_min")


@dataclass
class History:
    """Learning history of an :class:`~etsid.ets.ETS` model.

    Attributes
    ----------
    step : numpy.ndarray of int64, shape (K,)
        Sample counter k (1-based) of every learned sample.
    n_rules : numpy.ndarray of int64, shape (K,)
        Number of rules after learning sample k.
    potential : numpy.ndarray of float64, shape (K,)
        Potential P_k(z_k) of the sample (dimensionless, in (0, 1]).
    focal_max, focal_min : numpy.ndarray of float64, shape (K,)
        Largest and smallest focal-point potential after learning sample k.
    events : list of dict
        ``{"step": int, "kind": "birth" | "replace" | "removal", "rule_id": int}`` in order.
    snapshots : list of dict
        Every ``history_every`` steps: ``{"step": int, "rule_ids": int64 array (R,),
        "consequents": float64 array (R, n + 1, m)}``; consequent row 0 is the intercept
        and row j the coefficient of input j, in the original units of the data.
    """

    step: np.ndarray
    n_rules: np.ndarray
    potential: np.ndarray
    focal_max: np.ndarray
    focal_min: np.ndarray
    events: list[dict[str, Any]] = field(default_factory=list)
    snapshots: list[dict[str, Any]] = field(default_factory=list)

    def to_frame(self) -> pd.DataFrame:
        """One row per learned sample: step, n_rules, potential, focal_max, focal_min."""
        import pandas as pd

        return pd.DataFrame({name: getattr(self, name) for name in FRAME_COLUMNS})

    def events_frame(self) -> pd.DataFrame:
        """The events as a DataFrame with columns step, kind, rule_id."""
        import pandas as pd

        return pd.DataFrame(self.events, columns=["step", "kind", "rule_id"])


class HistoryRecorder:
    """Accumulates per-chunk arrays from the kernels and assembles a :class:`History`."""

    def __init__(self) -> None:
        self.chunks: list[tuple[int, np.ndarray]] = []
        self.events: list[dict[str, Any]] = []
        self.snapshots: list[dict[str, Any]] = []
        self._cache: History | None = None

    def add(self, first_step: int, hist: np.ndarray) -> None:
        """Store a (N, 4) block of history rows whose first row is step ``first_step``."""
        self.chunks.append((first_step, hist))
        self._cache = None

    def add_event(self, step: int, kind: str, rule_id: int) -> None:
        """Record one structural event."""
        self.events.append({"step": int(step), "kind": kind, "rule_id": int(rule_id)})
        self._cache = None

    def add_snapshot(self, step: int, rule_ids: np.ndarray, consequents: np.ndarray) -> None:
        """Record the consequents (original units) of the live rules at ``step``."""
        self.snapshots.append(
            {"step": int(step), "rule_ids": rule_ids.copy(), "consequents": consequents.copy()}
        )
        self._cache = None

    def build(self) -> History:
        """Concatenate the chunks into one :class:`History` (cached until the next change)."""
        if self._cache is None:
            if self.chunks:
                steps = np.concatenate(
                    [np.arange(s0, s0 + h.shape[0], dtype=np.int64) for s0, h in self.chunks]
                )
                h = np.concatenate([h for _, h in self.chunks], axis=0)
            else:
                steps = np.zeros(0, dtype=np.int64)
                h = np.zeros((0, 4))
            self._cache = History(
                step=steps,
                n_rules=h[:, 0].astype(np.int64),
                potential=h[:, 1].copy(),
                focal_max=h[:, 2].copy(),
                focal_min=h[:, 3].copy(),
                events=list(self.events),
                snapshots=list(self.snapshots),
            )
        return self._cache
