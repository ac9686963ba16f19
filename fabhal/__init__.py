"""FabHaL: a solver-aided language for fixture hacks."""

__version__ = "0.1.0"
