"""Fuzz of option values (hypothesis, deterministic; issue 14).

Any value of any ``dynid identify`` option, ``dynid offline`` filter option or
``OnlineSettings`` field either works or is refused with a ValueError/TypeError
whose message names it; never another exception, never a large allocation
(tracemalloc). The checks are the ones the commands run before any work
(``commands.identify.online_settings`` with the log's grid and the robot's size,
``core.idim_checks.check_offline_settings``); no identification is run.
"""

import argparse
import math
import tracemalloc

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drake_dynid.commands.identify import OPTION_NAMES, online_settings
from drake_dynid.core.idim_checks import check_offline_settings
from drake_dynid.core.online import OnlineSettings

BUDGET = 64e6  # bytes: far below any identification, far above a check

reals = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-320, 5e-324, 1e-9, 0.02, 0.4, 1.0, 2.0, 20.0]),
    st.sampled_from([1e5, 1e6, 1e300, -1.0, 499.9, 1e308]),
)
# Mostly unset (None) so that many examples reach the checks against the log.
maybe = lambda strategy: st.one_of(st.none(), st.none(), st.none(), strategy)  # noqa: E731
frequency_text = st.one_of(
    st.sampled_from(["paper", "auto", "0:1:7", "0:1e-7:100", "0:1:inf", ",", ""]),
    st.sampled_from(["nan", "0,0,1", "-1,2", "1:0:5", "a,b", "0:0.5:9.5", "1e308"]),
    st.lists(
        st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=6
    ).map(lambda values: ",".join(repr(v) for v in values)),
    st.tuples(reals, reals, reals).map(lambda v: ":".join(map(repr, v))),
)


def _namespace(**values):
    fields = (
        "model",
        "window",
        "bandwidth",
        "jacobi_window",
        "kappa",
        "mu",
        "jacobi_q",
        "bank_time_step",
        "update_period",
        "max_condition",
        "weighting",
        "frequencies",
        "raw_window",
        "uncertainty",
        "rows_from",
    )
    return argparse.Namespace(**{name: values.get(name) for name in fields})


def _bounded(call):
    """Runs ``call``; returns the error message or None; checks the allocation."""
    tracemalloc.start()
    try:
        try:
            call()
            message = None
        except (ValueError, TypeError) as error:
            message = str(error)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < BUDGET, f"{peak / 1e6:.0f} MB"
    return message


@settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(
    model=maybe(st.sampled_from(["lagrangian", "power"])),
    window=maybe(reals),
    bandwidth=maybe(reals),
    jacobi_window=maybe(reals),
    kappa=maybe(reals),
    mu=maybe(reals),
    jacobi_q=maybe(st.integers(-5, 10**6)),
    bank_time_step=maybe(reals),
    update_period=maybe(reals),
    max_condition=maybe(reals),
    weighting=maybe(st.sampled_from(["frequency", "none"])),
    frequencies=maybe(frequency_text),
    raw_window=maybe(reals),
    uncertainty=maybe(st.sampled_from(["jackknife", "sandwich", "gautier"])),
    rows_from=st.sampled_from(["auto", "filtered", "raw"]),
    time_step=st.sampled_from([1e-3, 8e-3, 1.0 / 909.0, 0.05]),
)
def test_identify_options_work_or_are_refused_by_name(time_step, **values):
    args = _namespace(**values)

    class Robot:
        num_joints = 2
        num_parameters = 8

    def call():
        online_settings(args)
        online_settings(args, None, time_step, 30.0, Robot())

    message = _bounded(call)
    if message is not None:
        named = [name for name in OPTION_NAMES.values() if name in message]
        assert named or "the log lasts" in message, message
        assert "OnlineSettings" not in message and "fourier_bank" not in message


@settings(max_examples=80, deadline=None)
@given(
    window=reals,
    bandwidth=reals,
    order=st.one_of(st.integers(-2, 20), reals),
    frequencies=st.one_of(
        st.none(),
        st.just("paper"),
        st.lists(reals, min_size=0, max_size=8),
        st.integers(0, 2000).map(lambda count: np.arange(float(count))),
        st.sampled_from(["dense", b"x", 3.0, [[1.0]], {"a": 1}]),
    ),
    kappa=reals,
    jacobi_q=st.one_of(st.integers(-3, 10**4), st.floats()),
)
def test_online_settings_values_work_or_raise_value_or_type_errors(**values):
    def call():
        built = OnlineSettings(**values)
        built.for_log(1e-3, 60.0, num_joints=2, num_parameters=8)

    message = _bounded(call)
    if message is not None:
        assert message.startswith("OnlineSettings: "), message


@pytest.fixture(scope="module")
def positions():
    t = np.arange(20000) * 1e-3
    rng = np.random.default_rng(7)  # seed 7: 1 mrad of position noise
    q = np.stack([np.sin(2 * np.pi * 0.4 * t), np.cos(2 * np.pi * 0.3 * t)], 1)
    return q + rng.normal(0.0, 1e-3, q.shape)


@settings(max_examples=80, deadline=None)
@given(
    cutoff=maybe(reals),
    decimation=maybe(st.one_of(st.integers(-3, 10**9), reals)),
    decimation_cutoff=maybe(reals),
)
def test_offline_filter_options_work_or_are_refused_by_name(
    positions, cutoff, decimation, decimation_cutoff
):
    names = {
        "cutoff_hz": "--cutoff",
        "decimation": "--decimation",
        "decimation_cutoff_hz": "--decimation-cutoff",
    }

    def call():
        check_offline_settings(
            positions,
            1e-3,
            [(0, positions.shape[0])],
            cutoff_hz=cutoff,
            decimation=decimation,
            decimation_cutoff_hz=decimation_cutoff,
            num_joints=2,
            num_parameters=8,
            owner=None,
            names=names,
        )

    message = _bounded(call)
    if message is not None:
        assert any(name in message for name in names.values()), message
    elif cutoff is not None:
        assert math.isfinite(cutoff) and 0.0 < cutoff < 500.0
