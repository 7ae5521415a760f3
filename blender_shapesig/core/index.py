"""The search's former name (``core.search`` since 28 Nov 2026), kept so that scripts written against earlier
docs (``from blender_shapesig.core import index``) keep working: the same names, nothing of its own."""

from .search import *  # noqa: F401,F403
from .search import __all__  # noqa: F401
