"""What an eTS model records while learning: per-step structure, events, consequent snapshots."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from etsid.ets.layout import EVENT_KINDS

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


def raw_consequents(Pi: np.ndarray, lo: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Consequents ``Pi`` (R, n + 1, m) on x_e = [1, (x - lo) / s] re-expressed in the
    original units: row 0 the intercept, row j the coefficient of input j."""
    out = np.empty_like(Pi)
    out[:, 1:, :] = Pi[:, 1:, :] / s[None, :, None]
    out[:, 0, :] = Pi[:, 0, :] - np.einsum("rjo,j->ro", out[:, 1:, :], lo)
    return out


class HistoryRecorder:
    """Accumulates per-chunk arrays from the kernels and assembles a :class:`History`.

    Events and snapshots from the kernels are kept as the arrays they wrote and turned
    into dicts (snapshots into original units) only when the history is built: learning
    does not pay for a history nobody reads.
    """

    def __init__(self) -> None:
        self.chunks: list[tuple[int, np.ndarray]] = []
        self.events: list[dict[str, Any]] = []
        self.snapshots: list[dict[str, Any]] = []
        self._kernel_events: list[np.ndarray] = []
        self._kernel_snapshots: list[tuple[np.ndarray, ...]] = []
        self._cache: History | None = None

    def add(self, first_step: int, hist: np.ndarray) -> None:
        """Store a (N, 4) block of history rows whose first row is step ``first_step``."""
        self.chunks.append((first_step, hist))
        self._cache = None

    def add_event(self, step: int, kind: str, rule_id: int) -> None:
        """Record one structural event."""
        self._convert()
        self.events.append({"step": int(step), "kind": kind, "rule_id": int(rule_id)})
        self._cache = None

    def add_events(self, ev: np.ndarray) -> None:
        """Record the kernel's events: int rows (step, kind, rule id), ``kind`` indexing
        ``layout.EVENT_KINDS``."""
        if ev.shape[0]:
            self._kernel_events.append(ev.copy())
            self._cache = None

    def add_snapshots(self, steps: np.ndarray, ids: np.ndarray, pi: np.ndarray,
                      lo: np.ndarray, s: np.ndarray) -> None:
        """Record the kernel's snapshots: steps (Q,), rule ids (Q, Rmax) (−1 beyond the
        live rules), normalised consequents (Q, Rmax, n + 1, m) and the consequent inputs'
        ``lo`` and widths ``s`` (Q, n) of each moment."""
        if steps.shape[0]:
            self._kernel_snapshots.append(tuple(a.copy() for a in (steps, ids, pi, lo, s)))
            self._cache = None

    def _convert(self) -> None:
        """Turn the kernels' pending events and snapshots into dicts, in order."""
        for ev in self._kernel_events:
            for step, kind, rid in ev.tolist():
                self.events.append({"step": step, "kind": EVENT_KINDS[kind], "rule_id": rid})
        self._kernel_events.clear()
        for steps, ids, pi, lo, s in self._kernel_snapshots:
            for q in range(steps.shape[0]):
                R = int(np.count_nonzero(ids[q] >= 0))
                self.snapshots.append({"step": int(steps[q]), "rule_ids": ids[q, :R].copy(),
                                       "consequents": raw_consequents(pi[q, :R], lo[q], s[q])})
        self._kernel_snapshots.clear()

    def build(self) -> History:
        """Concatenate the chunks into one :class:`History` (cached until the next change)."""
        if self._cache is None:
            self._convert()
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
