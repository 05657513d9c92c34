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


# ---------------------------------------------------------------- rank decision
NAMES_6 = ("A", "B", "C", "D", "E", "F")


def _rows_with_round_off(seed=12, num_rows=60):
    """Columns: A, B genuine; C = round-off of A's size (1e-13 relative, as left by a
    π rotation written with 11 digits); D = A + B (dependent); E exactly zero;
    F = 2A + 1e-10-relative noise (a near-dependence at 1e-10)."""
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(2, num_rows)) * [[10.0], [3.0]]
    noise = rng.normal(size=(2, num_rows))
    return np.stack(
        [
            a,
            b,
            1e-13 * 10 * noise[0],
            a + b,
            np.zeros(num_rows),
            2 * a + 1e-9 * noise[1],
        ],
        1,
    )


def test_round_off_columns_never_become_parameters():
    rows = _rows_with_round_off()
    base = base_parameters(rows, NAMES_6)
    assert base.names == ("AR", "BR")
    assert dict(base.definitions[0]) == {"A": 1.0, "D": 1.0, "F": 2.0}
    assert dict(base.definitions[1]) == {"B": 1.0, "D": 1.0}
    assert base.zero_columns == ("C", "E") and base.round_off_columns == ("C",)
    assert base.relative_norms[4] == 0.0 and 0 < base.relative_norms[2] < 1e-12
    assert base.clear and base.gap > 1e6 and base.singular_gap > 1e6
    assert base.smallest_kept > 0.1 and base.largest_dropped < 1e-8
    # The former rule (normalise every non-zero column, QR without pivoting) keeps
    # the round-off column C: unit round-off is a random, "independent" direction.
    scale = np.linalg.norm(rows, axis=0)
    unit = rows[:, scale > 0] / scale[scale > 0]
    diagonal = np.abs(np.diag(np.linalg.qr(unit, mode="r")))
    assert diagonal[2] > 0.5  # column C: it would have been a parameter


def test_small_genuine_columns_are_kept():
    # A column 1e-7 of the largest (a tilt of 1e-7 rad in a description) that is
    # independent is identifiable in exact arithmetic: it is kept.
    rng = np.random.default_rng(13)
    a, b = rng.normal(size=(2, 50))
    base = base_parameters(np.stack([a, 1e-7 * b, a], 1), ("A", "B", "C"))
    assert base.names == ("AR", "B") and base.zero_columns == ()
    # ... unless it is below the column tolerance, or its component outside the
    # span is round-off of the largest column (distance 1e-12 < 1e-10).
    base = base_parameters(
        np.stack([a, 1e-7 * b, a], 1), ("A", "B", "C"), column_tolerance=1e-6
    )
    assert base.names == ("AR",) and base.zero_columns == ("B",)
    base = base_parameters(np.stack([a, a + 1e-12 * b], 1), ("A", "B"))
    assert base.names == ("AR",) and dict(base.definitions[0]) == {"A": 1.0, "B": 1.0}


def test_a_tiny_dependent_column_leaves_no_round_off_coefficients():
    # D = 2e-7 A (the Kinova's M2: a tiny column regrouped with ZZ1) plus round-off
    # of the largest column: its least squares on the unit columns gave B and F
    # coefficients of 1e-15 (the Kinova's FV1R = FV1 + 3e-16 M2, a review).
    for seed in (16, 17):
        rng = np.random.default_rng(seed)
        a, b, f, e = rng.normal(size=(4, 60))
        rows = np.stack([10.0 * a, 3.0 * b, 0.3 * f, 2e-6 * a + 1e-14 * e], 1)
        base = base_parameters(rows, ("A", "B", "F", "D"))
        assert base.names == ("AR", "B", "F")
        assert dict(base.definitions[0]) == {"A": 1.0, "D": pytest.approx(2e-7)}
        assert [dict(d) for d in base.definitions[1:]] == [{"B": 1.0}, {"F": 1.0}]


def test_rank_matches_an_independent_svd_with_a_gap():
    rows = _rows_with_round_off(seed=14)
    s = np.linalg.svd(rows, compute_uv=False)
    gaps = s[:-1] / np.maximum(s[1:], 1e-300)
    rank = int(np.flatnonzero(gaps > 1e8)[0]) + 1
    assert rank == base_parameters(rows, NAMES_6).num_base == 2


def test_column_tolerance_is_checked():
    with pytest.raises(ValueError, match=r"column_tolerance must be in \[0.0, 1.0\]"):
        base_parameters(_rows_2r(1.0), NAMES_2R, column_tolerance=-1.0)
    with pytest.raises(ValueError, match="relative_norms must have 12 entries"):
        dataclasses.replace(
            base_parameters(_rows_2r(1.0), NAMES_2R), relative_norms=np.ones(3)
        )


def test_a_column_near_the_tolerance_is_not_clear():
    # Seed 15: C = A + 1e-7 c is independent, but only about 10x above the 1e-8
    # rank tolerance: kept, and the decision is flagged as not clear.
    rng = np.random.default_rng(15)
    a, b, c = rng.normal(size=(3, 50))
    base = base_parameters(np.stack([a, b, a + 1e-7 * c], 1), ("A", "B", "C"))
    assert base.names == ("A", "B", "C") and not base.clear
    assert 1.0 < base.margin_kept < 100.0 and base.margin_dropped == 0.0
    clean = base_parameters(np.stack([a, b, a + b], 1), ("A", "B", "C"))
    assert clean.clear and clean.margin_kept > 1e6 and clean.margin_dropped < 1e-6
