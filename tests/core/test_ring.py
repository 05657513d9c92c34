"""ChunkRing against a collections.deque model (value semantics, deep copies)."""

import collections
import copy

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_dynid.core.ring import ChunkRing


def _check(ring, model):
    expected = np.array(list(model)).reshape(-1, ring.channels)
    assert ring.size == len(model)
    np.testing.assert_array_equal(ring.window(), expected)
    assert ring.is_full == (len(model) == ring.capacity)
    if model:
        np.testing.assert_array_equal(ring.oldest, expected[0])
        np.testing.assert_array_equal(ring.newest, expected[-1])
        k = len(model) // 2
        np.testing.assert_array_equal(ring.head(k), expected[:k])


# One operation: ("push", version) | ("extend", version, count) | ("copy", version).
_operation = st.one_of(
    st.tuples(st.just("push"), st.integers(0, 1000)),
    st.tuples(st.just("extend"), st.integers(0, 1000), st.integers(0, 25)),
    st.tuples(st.just("copy"), st.integers(0, 1000)),
)


@settings(max_examples=60, deadline=None)
@given(
    capacity=st.integers(1, 20),
    channels=st.integers(1, 3),
    chunk_size=st.integers(1, 7),
    operations=st.lists(_operation, max_size=60),
)
def test_every_version_matches_a_deque(capacity, channels, chunk_size, operations):
    # Every version ever produced (including branches of old versions and deep
    # copies) must keep matching its own deque model: value semantics.
    versions = [(ChunkRing(capacity, channels, chunk_size=chunk_size), ())]
    counter = 0
    for operation in operations:
        ring, model = versions[operation[1] % len(versions)]
        if operation[0] == "push":
            sample = np.full(channels, float(counter)) + np.arange(channels) / 10
            counter += 1
            new_ring = ring.push(sample)
            new_model = collections.deque(model, maxlen=capacity)
            new_model.append(tuple(sample))
        elif operation[0] == "extend":
            count = operation[2]
            block = (np.arange(count)[:, None] + counter) + np.arange(channels) / 10
            counter += count
            new_ring = ring.extend(block)
            new_model = collections.deque(model, maxlen=capacity)
            new_model.extend(map(tuple, block))
        else:
            new_ring, new_model = copy.deepcopy(ring), model
        versions.append((new_ring, tuple(new_model)))
    for ring, model in versions:
        _check(ring, model)


def test_frozen_chunks_are_shared_and_deepcopy_copies_only_the_tail():
    ring = ChunkRing(1000, 4, chunk_size=10)
    ring = ring.extend(np.arange(4000.0).reshape(1000, 4)).push(np.ones(4))
    clone = copy.deepcopy(ring)
    assert all(a is b for a, b in zip(ring._chunks, clone._chunks, strict=True))
    assert clone._tail is not ring._tail
    np.testing.assert_array_equal(clone.window(), ring.window())
    # Frozen chunks cannot be written through a returned view.
    with pytest.raises(ValueError):
        ring.oldest[0] = 1.0
    with pytest.raises(ValueError):
        ring.newest[0] = 1.0


def test_push_does_not_change_the_original():
    ring = ChunkRing(3, 1, chunk_size=2).push([1.0]).push([2.0]).push([3.0])
    assert ring.push([4.0]).window().ravel().tolist() == [2.0, 3.0, 4.0]
    assert ring.push([5.0]).window().ravel().tolist() == [2.0, 3.0, 5.0]
    assert ring.window().ravel().tolist() == [1.0, 2.0, 3.0]


def test_validation():
    with pytest.raises(ValueError, match="capacity must be >= 1"):
        ChunkRing(0, 1)
    with pytest.raises(TypeError, match="channels must be an integer"):
        ChunkRing(3, 1.5)
    ring = ChunkRing(3, 2)
    with pytest.raises(ValueError, match=r"sample must have shape \(2,\)"):
        ring.push([1.0])
    with pytest.raises(ValueError, match="samples must have shape"):
        ring.extend(np.zeros((2, 3)))
    with pytest.raises(IndexError, match="empty"):
        _ = ring.oldest
    with pytest.raises(ValueError, match="count must be <= size 0"):
        ring.head(1)
