"""core.rows: the model-row contract (kinds, provider check, packing)."""

import numpy as np
import pytest

from drake_dynid.core.planar2r import Planar2RRows
from drake_dynid.core.rows import (
    MODEL_KINDS,
    RowProvider,
    check_model_kind,
    check_rows,
    num_channels,
    num_equations,
    pack_rows,
    unpack_rows,
)


def test_one_kind_check_for_every_owner():
    assert MODEL_KINDS == ("power", "lagrangian")
    assert check_model_kind("x", "power") == "power"
    with pytest.raises(ValueError, match="x: kind must be one of power, lagrangian"):
        check_model_kind("x", "energy")
    assert num_equations("power", 6) == 1 and num_equations("lagrangian", 6) == 6
    rows = Planar2RRows()
    for call in (
        lambda: rows.model_rows("energy", np.zeros(2), np.zeros(2), np.zeros(2)),
        lambda: rows.packed_rows("energy", np.zeros(2), np.zeros(2), np.zeros(2)),
    ):
        with pytest.raises(ValueError, match="Planar2RRows: kind must be one of"):
            call()


def test_provider_check_and_protocol():
    rows = Planar2RRows()
    assert isinstance(rows, RowProvider)
    assert check_rows("x", rows) == 2
    with pytest.raises(TypeError, match="x: rows must be a row provider"):
        check_rows("x", object())


def test_pack_and_unpack_are_inverse_and_match_the_fast_path():
    rng = np.random.default_rng(11)
    rows = Planar2RRows(L1=0.8, friction=("viscous", "coulomb", "offset"))
    q, v, tau = rng.normal(size=(3, 5, 2))
    for kind in MODEL_KINDS:
        d, g, y = rows.model_rows(kind, q, v, tau)
        packed = pack_rows(d, g, y)
        m, p = d.shape[1:]
        assert packed.shape == (5, num_channels(m, p))
        for got, want in zip(unpack_rows(packed, m, p), (d, g, y), strict=True):
            np.testing.assert_array_equal(got, want)
        fast = rows.packed_rows(kind, q[0], v[0], tau[0])
        np.testing.assert_allclose(fast, packed[0], rtol=1e-14, atol=1e-15)
