"""Array type aliases shared by the whole package, defined once.

``FloatArray`` is what every public function returns for real-valued data (time down the rows,
see the package's data layout); ``IntArray`` and ``BoolArray`` the index and mask arrays beside it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["BoolArray", "FloatArray", "IntArray"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]
