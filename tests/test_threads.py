import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from uqdrive.numerics.threads import single_blas_thread, with_single_blas_thread


def _blas_threads():
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


def test_single_blas_thread_limits_and_restores():
    """From two threads (the suite itself runs on one: tests/conftest.py) to one and back."""
    np.ones((2, 2)) @ np.ones((2, 2))  # BLAS loaded
    with threadpool_limits(limits=2, user_api="blas"):
        before = _blas_threads()
        assert before and all(n == 2 for n in before)
        with single_blas_thread():
            assert all(n == 1 for n in _blas_threads())
        assert _blas_threads() == before


def test_decorator_runs_the_function_with_one_thread():
    with threadpool_limits(limits=2, user_api="blas"):
        seen = with_single_blas_thread(_blas_threads)()
    assert seen and all(n == 1 for n in seen)
