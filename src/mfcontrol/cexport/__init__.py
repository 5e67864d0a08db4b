"""Export a controller as dependency-free C99 (:func:`export_c`), translated from the laws'
own source so that, in double, the C computes what mfcontrol computes bit for bit."""

from .export import export_c
from .source import CFLAGS, CSource, c_source

__all__ = ["CFLAGS", "CSource", "c_source", "export_c"]
