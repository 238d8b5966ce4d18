import numpy as np
import pytest

from uqdrive.rng import rng_stream


def test_streams_are_reproducible_and_independent():
    a = rng_stream(1, "parameters").standard_normal(5)
    assert np.array_equal(a, rng_stream(1, "parameters").standard_normal(5))
    assert not np.array_equal(a, rng_stream(1, "wind").standard_normal(5))
    assert not np.array_equal(a, rng_stream(1, "parameters", 3).standard_normal(5))


def test_unknown_stream_is_named():
    with pytest.raises(ValueError, match="unknown random stream 'weather'"):
        rng_stream(1, "weather")
