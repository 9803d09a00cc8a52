"""The scenes reference page (for the documentation site): `tiseg.setup.reference`, which
generates it from the one declaration of each scene key (kept under this name for the docs
hooks and scripts that import it)."""

from .setup.reference import descriptions, markdown

__all__ = ["descriptions", "markdown"]
