"""numba's ``njit`` for the package's compiled functions, with every load from numba's disk cache
checked to hold the function and signature asked for (:func:`._cache.check_numba_cache_loads`)."""

from numba import njit

from ._cache import check_numba_cache_loads

check_numba_cache_loads()

__all__ = ["njit"]
