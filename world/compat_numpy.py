"""What fuzzynav takes from numpy beyond its public API, in one place, checked.

``np.einsum`` spends about 5 us of an 8 us call on one row in its Python wrapper,
before it calls the C function ``c_einsum`` (for two operands without ``optimize``).
The plant's step (:func:`world.husky.step_product`) runs every control period, so it
calls ``c_einsum`` itself: the same function, so the same bits. Where numpy keeps it
elsewhere, :data:`einsum` is ``np.einsum`` (the same numbers, more slowly).
``tests/test_compat.py`` fails loudly when a numpy of the supported major version
lacks it, or when it and ``np.einsum`` disagree by one bit.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["SUPPORTED_MAJOR", "FAST", "einsum"]

#: The numpy major version whose private ``c_einsum`` is used.
SUPPORTED_MAJOR = "2"

try:
    from numpy._core import _multiarray_umath as _umath  # type: ignore[attr-defined]
except ImportError:  # pragma: no cover - another numpy: the public function
    _umath = None  # type: ignore[assignment]
_c_einsum: Any = getattr(_umath, "c_einsum", None)

#: ``c_einsum`` was found, on the supported major version.
FAST = _c_einsum is not None and np.__version__.split(".")[0] == SUPPORTED_MAJOR
#: ``c_einsum``, or ``np.einsum`` where this module cannot vouch for it.
einsum: Callable[..., Any] = _c_einsum if FAST else np.einsum
