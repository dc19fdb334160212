"""starid's exceptions (defined in the native module)."""

from ._starid import CatalogError, StaridError

__all__ = ["CatalogError", "StaridError"]
