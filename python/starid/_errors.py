"""starid's exceptions (defined in the native module)."""

from ._starid import CatalogError, InvalidInputError, StaridError

__all__ = ["CatalogError", "InvalidInputError", "StaridError"]
