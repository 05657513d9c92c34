"""Choosing the model rows from the log's position noise (filtered or raw rows).

Synthetic positions: two sinusoids (0.5 and 0.3 Hz, amplitudes 1 and 0.5 rad) at
1 kHz plus white noise from default_rng(0); the noise level is known, so the
measured σ and the decision can be checked against it.
"""

import json

import numpy as np
import pytest

from drake_dynid import cli
from drake_dynid.core.excitation import position_noise_std, velocity_rms
from drake_dynid.core.raw_rows import (
    RAW_NOISE_COEFFICIENT,
    raw_noise_threshold,
    raw_rows_design,
    rows_from_noise,
)
from drake_dynid.logs import write_log
from drake_dynid.robot import RobotModel
from drake_dynid.urdf import model_path

H = 1e-3
T = H * np.arange(20000)
Q = np.stack([np.sin(2 * np.pi * 0.5 * T), 0.5 * np.cos(2 * np.pi * 0.3 * T)], 1)


@pytest.mark.parametrize("sigma", [1e-4, 1e-3, 1e-2])
def test_position_noise_and_velocity_rms_are_measured(sigma):
    noisy = Q + sigma * np.random.default_rng(0).standard_normal(Q.shape)
    np.testing.assert_allclose(position_noise_std(noisy, H), sigma, rtol=0.05)
    rms = [2 * np.pi * 0.5 / np.sqrt(2), 2 * np.pi * 0.3 * 0.5 / np.sqrt(2)]
    np.testing.assert_allclose(velocity_rms(noisy, H), rms, rtol=0.01)


def test_rows_follow_the_noise_of_the_raw_velocity():
    band, window = 0.6, 0.4  # [Hz], [s]
    limit = raw_noise_threshold(band, window)
    assert limit == pytest.approx(RAW_NOISE_COEFFICIENT * (2 * np.pi * 0.24) ** 2)
    gain = raw_rows_design(0.2, H, 1).velocity.noise_gain
    slow = 2 * np.pi * 0.3 * 0.5 / np.sqrt(2)  # the slower joint decides
    sigma = limit * slow / gain  # [rad]: the position noise at the threshold
    rng = np.random.default_rng(0)
    options = dict(raw_window=0.2, jacobi_window=window, bandwidth=band)
    rows, ratio, threshold = rows_from_noise(Q, H, **options)
    assert rows == "raw" and ratio < 1e-9 and threshold == limit
    noisy = Q + 0.5 * sigma * rng.standard_normal(Q.shape)
    rows, ratio, _ = rows_from_noise(noisy, H, **options)
    assert rows == "raw" and ratio == pytest.approx(0.5 * limit, rel=0.1)
    noisy = Q + 2.0 * sigma * rng.standard_normal(Q.shape)
    rows, ratio, _ = rows_from_noise(noisy, H, **options)
    assert rows == "filtered" and ratio == pytest.approx(2.0 * limit, rel=0.1)
    # A shorter Jacobi window biases less: the same noise calls for filtered rows.
    half = rows_from_noise(
        Q + 0.5 * sigma * rng.standard_normal(Q.shape),
        H,
        raw_window=0.2,
        jacobi_window=0.2,
        bandwidth=band,
    )
    assert half[0] == "filtered"
    assert rows_from_noise(np.zeros((200, 2)), H, **options)[:2] == ("filtered", np.inf)


def test_cli_auto_picks_filtered_rows_on_noisy_positions(tmp_path, capsys):
    """SNR 30 dB on q (σ = 0.022 rad on joint 1): the filtered rows."""
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    rng = np.random.default_rng(1)
    q = Q[:6000] + 0.03 * Q.std(axis=0) * rng.standard_normal((6000, 2))
    tau = rng.normal(size=(6000, 2))  # the decision reads q only
    path = tmp_path / "log.csv"
    write_log(path, T[:6000], q, tau, robot.joint_names)
    out = tmp_path / "out.json"
    argv = ["identify", str(path), "--urdf", model_path("planar_2r"), "--window", "4"]
    argv += ["--jacobi-window", "0.1", "--json", str(out)]
    assert cli.main(argv) == 0
    assert "rows: filtered (raw velocity noise" in capsys.readouterr().out
    settings = json.loads(out.read_text())["settings"]
    assert settings["rows_from"] == "filtered" and settings["rows_from_measured"]
    assert settings["raw_noise_ratio"] > settings["raw_noise_threshold"] > 0
    assert cli.main([*argv, "--rows-from", "raw", "--raw-window", "0.05"]) == 0
    assert "rows:" not in capsys.readouterr().out  # chosen by the user
    settings = json.loads(out.read_text())["settings"]
    assert settings["rows_from"] == "raw" and settings["raw_window"] == 0.05
    assert settings["rows_from_measured"] is False
    assert settings["raw_noise_ratio"] is None
    assert settings["raw_noise_threshold"] is None
    # A raw window that does not fit the differentiator's ring: exit 2.
    assert cli.main([*argv, "--rows-from", "raw", "--raw-window", "0.2"]) == 2
    assert "--raw-window + --bank-time-step must be <=" in capsys.readouterr().err


def test_the_cli_help_states_the_threshold():
    import argparse

    from drake_dynid.commands import identify

    parser = argparse.ArgumentParser()
    identify.add_arguments(parser)
    text = " ".join(parser.format_help().split())
    assert f"is below {RAW_NOISE_COEFFICIENT:g}·(2π·band·jacobi window)²" in text


def test_motion_and_noise_by_pieces_on_long_logs(monkeypatch):
    """One periodogram gives both statistics; past ``SPECTRUM_PIECE`` samples they
    are mean squares over equal pieces, one joint at a time (bounded memory on
    hour-long logs), still the known σ and RMS velocity."""
    from drake_dynid.core import excitation

    noisy = Q + 1e-3 * np.random.default_rng(0).standard_normal(Q.shape)
    rms, noise = excitation.motion_and_noise(noisy, H)
    np.testing.assert_array_equal(rms, velocity_rms(noisy, H))
    np.testing.assert_array_equal(noise, position_noise_std(noisy, H))
    monkeypatch.setattr(excitation, "SPECTRUM_PIECE", 12000)  # 2 pieces of 10 s
    pieces_rms, pieces_noise = excitation.motion_and_noise(noisy, H)
    np.testing.assert_allclose(pieces_noise, 1e-3, rtol=0.05)
    np.testing.assert_allclose(position_noise_std(noisy, H), pieces_noise, rtol=0)
    np.testing.assert_allclose(pieces_rms, rms, rtol=0.02)
    assert not np.array_equal(pieces_rms, rms)  # the pieces were taken


def test_motion_noise_band_is_the_two_measures_from_one_periodogram(monkeypatch):
    """``motion_noise_band``: ``motion_and_noise`` and ``estimate_bandwidth``'s
    band (None without motion), bit for bit; past ``SPECTRUM_PIECE`` samples the
    band of the pieces' summed velocity spectra (``velocity_bandwidth``'s rule)."""
    from drake_dynid.core import excitation
    from drake_dynid.core.idim_auto import measured_velocity_band

    noisy = Q + 1e-3 * np.random.default_rng(0).standard_normal(Q.shape)
    rms, noise, band = excitation.motion_noise_band(noisy, H)
    np.testing.assert_array_equal(rms, velocity_rms(noisy, H))
    np.testing.assert_array_equal(noise, position_noise_std(noisy, H))
    assert band == excitation.estimate_bandwidth(noisy, H)
    assert band == measured_velocity_band(noisy, H)
    still = np.full((200, 2), 0.3)
    assert excitation.motion_noise_band(still, H)[2] is None
    assert measured_velocity_band(still, H) is None
    monkeypatch.setattr(excitation, "SPECTRUM_PIECE", 12000)  # 2 pieces of 10 s
    power = 0.0
    for piece in excitation.record_pieces(noisy):
        spectra = [excitation.velocity_spectrum(piece[:, j], H) for j in range(2)]
        f = spectra[0][0]
        power = power + np.hstack([p for _, p in spectra])
    cumulative = np.cumsum(power, axis=0) / power.sum(axis=0)
    expected = max(f[np.searchsorted(c, 0.99 - 1e-12)] for c in cumulative.T)
    pieces = excitation.motion_noise_band(noisy, H)
    assert pieces[2] == expected
    assert measured_velocity_band(noisy, H) == expected
    rms, noise = excitation.motion_and_noise(noisy, H)
    np.testing.assert_array_equal(pieces[0], rms)
    np.testing.assert_array_equal(pieces[1], noise)
