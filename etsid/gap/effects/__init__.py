"""The effect registry of ``etsid gap``: one :class:`Effect` per vocabulary name.

The registry is the authority on names: gap.schema.json's effect enum, the CLI help and
docs/gap.md's vocabulary table are generated from it (:func:`vocabulary`,
:func:`docs_table`).
"""

from etsid.gap.effects.base import Effect, Prior
from etsid.gap.effects.registry import REGISTRY, docs_table, effect, vocabulary

__all__ = ["REGISTRY", "Effect", "Prior", "docs_table", "effect", "vocabulary"]
