"""One BLAS thread for the small-matrix kernels (PCE models, identification): OpenBLAS threads
make products and solves of tens-by-tens matrices about twice as slow on a 2-core machine.
"""

from __future__ import annotations

import functools

from threadpoolctl import ThreadpoolController

__all__ = ["single_blas_thread", "with_single_blas_thread"]


@functools.cache
def _controller() -> ThreadpoolController:
    # Scanning the loaded libraries costs ~1 ms; once scanned, a limit costs ~10 us.
    return ThreadpoolController()


def single_blas_thread():
    """Context manager that limits BLAS to one thread and restores the previous setting."""
    return _controller().limit(limits=1, user_api="blas")


def with_single_blas_thread(function):
    """Decorator: run ``function`` under :func:`single_blas_thread`."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        with single_blas_thread():
            return function(*args, **kwargs)

    return wrapper
