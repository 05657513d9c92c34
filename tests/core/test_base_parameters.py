"""Numerical base parameters: Khalil's set for the 2R arm, generic rank, immutability.

Seeds: numpy default_rng(3), (11), (12).
"""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_dynid.core.base_parameters import (
    BaseParameters,
    base_parameters,
    format_definition,
)

NAMES_2R = (
    "XX1",
    "ZZ1",
    "MX1",
    "M1",
    "ZZ2",
    "MX2",
    "MY2",
    "M2",
    "FV1",
    "FC1",
    "FV2",
    "FC2",
)


def _rows_2r(L1, seed=3, n=30):
    """IDIM rows of the 2R arm in standard columns (XX1, MX1, M1 do not appear)."""
    rng = np.random.default_rng(seed)
    q2 = rng.uniform(-np.pi, np.pi, n)
    v1, v2, a1, a2 = rng.normal(size=(4, n))
    c2, s2 = np.cos(q2), np.sin(q2)
    rows = np.zeros((n, 2, len(NAMES_2R)))
    rows[:, 0, 1] = a1
    rows[:, 0, 4] = rows[:, 1, 4] = a1 + a2
    rows[:, 0, 5] = L1 * (c2 * (2 * a1 + a2) - s2 * (2 * v1 * v2 + v2**2))
    rows[:, 0, 6] = -L1 * (s2 * (2 * a1 + a2) + c2 * (2 * v1 * v2 + v2**2))
    rows[:, 1, 5] = L1 * (c2 * a1 + s2 * v1**2)
    rows[:, 1, 6] = L1 * (-s2 * a1 + c2 * v1**2)
    rows[:, 0, 7] = L1**2 * a1  # M2 moves with link 1 at distance L1
    rows[:, 0, 8], rows[:, 0, 9] = v1, np.sign(v1)
    rows[:, 1, 10], rows[:, 1, 11] = v2, np.sign(v2)
    return rows.reshape(-1, len(NAMES_2R))


@pytest.mark.parametrize(("L1", "coefficient"), [(1.0, 1.0), (0.7, 0.49)])
def test_2r_gives_khalils_set(L1, coefficient):
    base = base_parameters(_rows_2r(L1), NAMES_2R)
    assert base.names == ("ZZ1R", "ZZ2", "MX2", "MY2", "FV1", "FC1", "FV2", "FC2")
    assert dict(base.definitions[0]) == {"ZZ1": 1.0, "M2": coefficient}
    assert base.definition_text("ZZ1R") == f"ZZ1 + {coefficient!r} M2"
    assert base.num_standard == 12 and base.num_base == 8
    theta = np.arange(1.0, 13.0)
    assert base.values(theta)[0] == theta[1] + coefficient * theta[7]
    assert base.largest_dropped < 1e-12 < 1e-3 < base.smallest_kept


def _random_dependent_rows(seed, rank, width, num_rows=80):
    rng = np.random.default_rng(seed)
    mix = rng.integers(-2, 3, size=(rank, width)).astype(float)
    mix[:, rng.choice(width, 2, replace=False)] = 0.0  # two zero columns
    return rng.normal(size=(num_rows, rank)) @ mix


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), rank=st.integers(1, 8))
def test_reduction_preserves_every_row(seed, rank):
    rows = _random_dependent_rows(seed, rank, 12)
    names = tuple(f"P{k}" for k in range(12))
    base = base_parameters(rows, names)
    assert base.num_base == np.linalg.matrix_rank(rows) <= rank
    theta = np.random.default_rng(seed + 1).normal(size=12)
    # Definitions are rounded to 10 significant digits; random integer mixes can
    # make the regrouping ill-conditioned (1e3), hence rtol 1e-6 here (the robots'
    # identities are checked to 1e-9 elsewhere).
    np.testing.assert_allclose(
        base.rows(rows) @ base.values(theta), rows @ theta, rtol=1e-6, atol=1e-8
    )
    # The leading standard parameter of each base parameter has coefficient 1.
    for i, column in enumerate(base.independent):
        assert base.matrix[i, column] == 1.0
        assert next(iter(base.definitions[i])) == names[column]


def test_greedy_keeps_the_earliest_columns():
    rng = np.random.default_rng(11)
    a, b = rng.normal(size=(2, 40))
    rows = np.stack([a, 2 * a, b, a - b], 1)
    base = base_parameters(rows, ("A", "B", "C", "D"))
    assert base.names == ("AR", "CR")
    assert dict(base.definitions[0]) == {"A": 1.0, "B": 2.0, "D": 1.0}
    assert dict(base.definitions[1]) == {"C": 1.0, "D": -1.0}


def test_a_column_of_round_off_is_zero_not_independent():
    # Seed 12. A parameter that does not enter the model can come out of the rows
    # as 1e-15-sized products (MZ2 of an arm with a vertical joint 1); normalised,
    # such noise is independent of everything, so it must be dropped as zero.
    rows = _rows_2r(1.0)
    noise = 1e-15 * np.random.default_rng(12).normal(size=rows.shape[0])
    rows[:, NAMES_2R.index("MX1")] = noise
    base = base_parameters(rows, NAMES_2R)
    assert base.names == ("ZZ1R", "ZZ2", "MX2", "MY2", "FV1", "FC1", "FV2", "FC2")


def test_base_parameters_is_immutable():
    base = base_parameters(_rows_2r(1.0), NAMES_2R)
    with pytest.raises(dataclasses.FrozenInstanceError):
        base.names = ()
    with pytest.raises(ValueError, match="read-only"):
        base.matrix[0, 0] = 2.0
    with pytest.raises(TypeError):
        base.definitions[0]["ZZ1"] = 2.0
    assert isinstance(base, BaseParameters)


def test_format_definition():
    assert (
        format_definition({"XX2": 1.0, "ZZ2": -1.0, "M3": 0.18})
        == "XX2 - 1.0 ZZ2 + 0.18 M3"
    )


def test_errors():
    rows = _rows_2r(1.0)
    with pytest.raises(ValueError, match="one column per standard name"):
        base_parameters(rows, NAMES_2R[:-1])
    with pytest.raises(ValueError, match="at least as many rows as columns"):
        base_parameters(rows[:5], NAMES_2R)
    with pytest.raises(ValueError, match="all zero"):
        base_parameters(np.zeros((5, 2)), ("A", "B"))
    with pytest.raises(ValueError, match=r"tolerance must be in \[0.0, 1.0\]"):
        base_parameters(rows, NAMES_2R, tolerance=2.0)
    base = base_parameters(rows, NAMES_2R)
    with pytest.raises(ValueError, match="12 columns"):
        base.rows(np.zeros((3, 5)))
    with pytest.raises(ValueError, match="name must be one of"):
        base.definition_text("ZZ1")
