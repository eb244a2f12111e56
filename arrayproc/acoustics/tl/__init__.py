"""Transmission loss TL(range, source depth, receiver depth), dB re 1 m.

Backends: bundled/computed tables with bilinear interpolation (:mod:`.table`), BELLHOP through
bellhopcxx or Fortran BELLHOP (:mod:`.bellhop`, reading ``.shd`` files with :mod:`.shd`), RAM PE
through pyram (:mod:`.ram`) and closed forms (:mod:`.closed`).
"""

from arrayproc.acoustics.tl.closed import (
           cylindrical,
           spherical,
           spherical_to_cylindrical,
           thorp_db_per_km,
)
from arrayproc.acoustics.tl.shd import ShadeFile, read_shd, write_shd
from arrayproc.acoustics.tl.table import TLTable, default_table_path, load_default_table

__all__ = ["TLTable", "default_table_path", "load_default_table", "ShadeFile", "read_shd",
           "write_shd", "spherical", "cylindrical", "spherical_to_cylindrical",
           "thorp_db_per_km"]
