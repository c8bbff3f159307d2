"""The cyclic garbage collector paused while modes are derived.

Deriving a mode makes many objects and hardly any cyclic garbage, and the
collections its allocations trigger walk every object the earlier modes left
(a scene's thousand modes and their expressions), so that a mode's cost grew
with the modes before it.  Paused, the collector makes one young collection
of the block's allocations after it; an instant that derives a cascade of
modes (the pinnacles of a 1000-ball chain) is one block, whose objects are
then collected once instead of being walked again by the older generations'
collections at every few modes (1000 balls: 5.0 → 1.6 s of collection).
"""

from __future__ import annotations

import contextlib
import gc

__all__ = ["collection_paused"]


@contextlib.contextmanager
def collection_paused():
    """No automatic cyclic garbage collection inside the block; switched back on after it if it was on
    (a block inside another leaves it off)."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            gc.enable()
