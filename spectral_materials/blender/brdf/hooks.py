"""What other capabilities do when a material's stored factor packs change.

An applied EEVEE node group samples a material's factor image, so it must follow the
factors: be rebuilt when they are stored again, and go before they are removed. The
EEVEE package sits above this one and adds its functions here when it registers; the
factor-pack code calls them without knowing who listens.
"""

from __future__ import annotations

from collections.abc import Callable

#: ``hook(material, scene) -> note`` after new factors were stored on ``material``;
#: a non-empty note is added to the job's summary.
AFTER_STORE: list[Callable[..., str]] = []
#: ``hook(material, scene)`` before ``material``'s factors are removed.
BEFORE_CLEAR: list[Callable[..., None]] = []


def after_store(material, scene) -> list[str]:
    """Run the :data:`AFTER_STORE` hooks; their notes."""
    return [hook(material, scene) for hook in AFTER_STORE]


def before_clear(material, scene) -> None:
    """Run the :data:`BEFORE_CLEAR` hooks."""
    for hook in BEFORE_CLEAR:
        hook(material, scene)
