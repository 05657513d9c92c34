"""Physical consistency: pseudo-inertia, feasibility check, constrained fit, projection.

Independent truths: robots made of random point masses (consistent by
construction), and a local optimiser over J = L Lᵀ (every J ⪰ 0 by construction)
for the optimality of the semidefinite program. Seeds: default_rng(0), (1), (2),
(3), (5).
"""

import json

import numpy as np
import pytest
from scipy import optimize

from drake_dynid.core.idim import reduce_rows
from drake_dynid.physical import (
    PhysicalResult,
    check_physical,
    link_names,
    parameter_scales,
    project_physical,
    pseudo_inertia,
    solve_physical,
    solve_physical_reduced,
)
from drake_dynid.plants import RobotModel, model_path


@pytest.fixture(scope="module")
def robot_2r():
    return RobotModel.from_urdf(model_path("planar_2r"))


@pytest.fixture(scope="module")
def iiwa():
    return RobotModel.from_urdf(model_path("iiwa7"))


def _point_mass_link(rng, centre, spread, mass):
    """[XX XY XZ YY YZ ZZ MX MY MZ M] of 4 point masses, and their pseudo-inertia."""
    masses = mass * rng.uniform(0.1, 0.5, 4)
    points = centre + spread * rng.normal(size=(4, 3))
    inertia = sum(
        m * (p @ p * np.eye(3) - np.outer(p, p))
        for m, p in zip(masses, points, strict=True)
    )
    first = masses @ points
    theta = [*inertia[0], inertia[1, 1], inertia[1, 2], inertia[2, 2], *first]
    theta.append(masses.sum())
    pseudo = sum(
        m * np.outer(np.r_[p, 1.0], np.r_[p, 1.0])
        for m, p in zip(masses, points, strict=True)
    )
    return np.array(theta), pseudo


def _random_robot(robot, rng):
    """Standard values of a random consistent robot (point masses, friction > 0)."""
    values = np.array(robot.standard_values, dtype=float)
    index = {name: k for k, name in enumerate(robot.standard_names)}
    for j in range(1, robot.num_joints + 1):
        names = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
        centre = np.array([values[index[f"M{n}{j}"]] for n in "XYZ"])
        centre /= max(values[index[f"M{j}"]], 1e-9)
        theta, _ = _point_mass_link(rng, centre, 0.1, 4.0)
        for name, value in zip(names, theta, strict=True):
            values[index[f"{name}{j}"]] = value
        if f"IA{j}" in index:
            values[index[f"IA{j}"]] = rng.uniform(0.0, 0.5)
    for name, k in index.items():
        if name.startswith(("FV", "FC")):
            values[k] = rng.uniform(0.05, 1.0)
    return values


def test_pseudo_inertia_of_point_masses():
    rng = np.random.default_rng(0)
    for _ in range(5):
        theta, expected = _point_mass_link(rng, rng.normal(size=3), 0.3, 2.0)
        np.testing.assert_allclose(pseudo_inertia(theta), expected, atol=1e-12)
        assert np.linalg.eigvalsh(pseudo_inertia(theta)).min() > -1e-12
    with pytest.raises(ValueError, match=r"link_parameters must have shape \(10,\)"):
        pseudo_inertia(np.zeros(9))


def test_urdf_and_random_point_mass_robots_are_consistent(robot_2r, iiwa):
    assert link_names(robot_2r) == ("link1", "link2")
    rng = np.random.default_rng(1)
    for robot in (robot_2r, iiwa):
        check = check_physical(robot, robot.base_values)
        assert check.consistent and check.feasible and check.negative == ()
        assert "physically consistent" in check.summary()
        for _ in range(3):
            theta = robot.base.values(_random_robot(robot, rng))
            check = check_physical(robot, theta)
            assert check.consistent, check.summary()
            assert check.link_slack.max() < 1e-6


def test_impossible_estimates_are_named(robot_2r, iiwa):
    names = robot_2r.base.names
    theta = robot_2r.base_values.copy()
    theta[names.index("ZZ2")] = -0.1  # negative inertia about the joint-2 axis
    check = check_physical(robot_2r, theta)
    assert not check.consistent and not check.feasible
    assert check.infeasible_links == ("link2",)
    assert "ZZ2" in check.involved and check.link_slack[1] > 1e-3
    assert "link2" in check.summary() and "ZZ2" in check.summary()
    theta = robot_2r.base_values.copy()
    theta[names.index("FC1")] = -0.2
    check = check_physical(robot_2r, theta)
    assert check.negative == ("FC1",) and check.feasible and not check.consistent
    assert "FC1" in check.summary()
    # A mass moment larger than any mass the regrouped ZZ1R leaves room for.
    theta = robot_2r.base_values.copy()
    theta[names.index("MX2")] = 3.0  # |m c| = 3 kg·m needs m·ZZ2 >= 9: m >= 36 kg
    check = check_physical(robot_2r, theta)
    assert not check.feasible and check.infeasible_links
    # The iiwa: a link's inertia made negative.
    names = iiwa.base.names
    theta = iiwa.base_values.copy()
    theta[names.index("ZZ7")] = -0.01
    check = check_physical(iiwa, theta)
    assert not check.consistent and "ZZ7" in check.involved
    with pytest.raises(ValueError, match=r"theta must have shape \(8,\)"):
        check_physical(robot_2r, np.zeros(3))


def _rows(robot, seed, samples=400):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (samples, robot.num_joints))
    v, vdot = rng.normal(size=(2, samples, robot.num_joints))
    return robot.idim_rows(q, v, vdot)


def _objective(robot, W, tau, standard, regularization):
    """(‖Wθ − τ‖² − ρ²)/σ̂² + λ‖(θ_std − θ_URDF)/s‖², as documented."""
    scales, _, _ = parameter_scales(robot)
    prior = (standard - robot.standard_values) / scales
    return _data_cost(robot, W, tau, standard) + regularization * prior @ prior


def _data_cost(robot, W, tau, standard):
    """(‖Wθ − τ‖² − ρ²)/σ̂²: the data term above the unconstrained optimum."""
    A, b = W.reshape(-1, W.shape[-1]), tau.reshape(-1)
    fit = np.linalg.lstsq(A, b, rcond=None)[0]
    rho2 = float(np.sum((A @ fit - b) ** 2))
    sigma2 = rho2 / (A.shape[0] - A.shape[1])
    residual = A @ robot.base.values(standard) - b
    return (residual @ residual - rho2) / sigma2


def _to_cholesky(robot):
    """The URDF's values as :func:`_from_cholesky`'s z (a search's start)."""
    values = robot.standard_values
    links = [
        np.linalg.cholesky(pseudo_inertia(values[10 * j : 10 * j + 10]))[
            np.tril_indices(4)
        ]
        for j in range(robot.num_joints)
    ]
    return np.concatenate([*links, np.sqrt(values[10 * robot.num_joints :])])


def _from_cholesky(robot, z):
    """Standard values from 10 Cholesky entries per link (J = L Lᵀ) + √friction."""
    values = np.array(robot.standard_values, dtype=float)
    rows, cols = np.tril_indices(4)
    for j in range(robot.num_joints):
        lower = np.zeros((4, 4))
        lower[rows, cols] = z[10 * j : 10 * j + 10]
        pseudo = lower @ lower.T
        sigma, first, mass = pseudo[:3, :3], pseudo[:3, 3], pseudo[3, 3]
        inertia = np.trace(sigma) * np.eye(3) - sigma
        values[10 * j : 10 * j + 10] = [
            *inertia[0],
            inertia[1, 1],
            inertia[1, 2],
            inertia[2, 2],
            *first,
            mass,
        ]
    values[10 * robot.num_joints :] = z[10 * robot.num_joints :] ** 2
    return values


def test_constrained_fit_is_the_global_optimum_of_the_documented_problem(robot_2r):
    # Torques of a non-physical 2R (ZZ2 < 0, FC2 < 0) with noise: the constraints
    # must bind, and no consistent robot may fit better (local optimiser over
    # J = L Lᵀ, friction = z², started from the URDF).
    W = _rows(robot_2r, 2)
    theta = robot_2r.base_values.copy()
    theta[1] = -0.05
    theta[7] = -0.1
    rng = np.random.default_rng(3)
    tau = W @ theta + 0.05 * rng.normal(size=W.shape[:2])
    result = solve_physical(robot_2r, W, tau, regularization=1e-3)
    assert isinstance(result, PhysicalResult) and result.solver == "Clarabel"
    assert "J(link2) ⪰ 0" in result.active and "FC2 >= 0" in result.active
    assert check_physical(robot_2r, result.theta).consistent
    np.testing.assert_allclose(
        result.theta, robot_2r.base.values(result.standard_values), atol=1e-12
    )
    sdp = _objective(robot_2r, W, tau, result.standard_values, 1e-3)
    start = _to_cholesky(robot_2r)
    local = optimize.minimize(
        lambda z: _objective(robot_2r, W, tau, _from_cholesky(robot_2r, z), 1e-3),
        start,
        method="BFGS",
        options={"gtol": 1e-9, "maxiter": 5000},
    )
    assert sdp <= local.fun + 1e-4 * abs(local.fun) + 1e-6
    assert local.fun <= sdp + 1e-3 * abs(sdp) + 1e-3  # the optimiser found it too
    assert result.data_cost > 10.0  # the data wanted a non-physical robot


def test_consistent_estimates_are_kept_and_unseen_directions_stay_at_the_urdf(iiwa):
    W = _rows(iiwa, 5, samples=300)
    tau = W @ iiwa.base_values + 1e-3 * np.random.default_rng(5).normal(
        size=W.shape[:2]
    )
    result = solve_physical(iiwa, W, tau)
    fit = np.linalg.lstsq(W.reshape(-1, W.shape[-1]), tau.reshape(-1), rcond=None)[0]
    assert result.active == ()
    np.testing.assert_allclose(result.theta, fit, rtol=1e-4, atol=1e-6)
    # The standard values the data cannot see (M1, the link masses regrouped with
    # inertias) stay at the URDF's.
    values = result.standard_parameters()
    assert values["M1"] == pytest.approx(iiwa.standard_parameters()["M1"], rel=1e-6)
    weighted = solve_physical(iiwa, W, tau, weighted=True)
    np.testing.assert_allclose(weighted.theta, result.theta, rtol=1e-3, atol=1e-5)
    # The rows reduced a block at a time (as identify_offline keeps them, whatever
    # the log's length): the same program to round-off.
    reduced = None
    for start in range(0, W.shape[0], 70):
        reduced = reduce_rows(W[start : start + 70], tau[start : start + 70], reduced)
    for weights in (False, True):
        blocks = solve_physical_reduced(iiwa, reduced, weighted=weights)
        whole = weighted if weights else result
        np.testing.assert_allclose(blocks.theta, whole.theta, rtol=1e-6, atol=1e-9)
    with pytest.raises(TypeError, match="reduced must be a ReducedRows"):
        solve_physical_reduced(iiwa, (W, tau))


def test_projection_is_the_closest_consistent_point(robot_2r):
    rng = np.random.default_rng(0)
    p = robot_2r.num_parameters
    mix = rng.normal(size=(p, p))
    covariance = 1e-4 * (mix @ mix.T + p * np.eye(p))
    # A consistent estimate comes back (up to the regularisation).
    kept = project_physical(robot_2r, robot_2r.base_values, covariance)
    np.testing.assert_allclose(kept.theta, robot_2r.base_values, rtol=1e-5)
    assert kept.data_cost < 1e-6
    # An impossible one moves to a consistent point no farther (in C⁻¹) than any
    # consistent robot we can build.
    estimate = robot_2r.base_values.copy()
    estimate[1] = -0.02  # ZZ2
    estimate[4] = -0.05  # FV1
    result = project_physical(robot_2r, estimate, covariance)
    assert check_physical(robot_2r, result.theta).consistent
    inverse = np.linalg.inv(covariance)

    def distance(theta):
        return (theta - estimate) @ inverse @ (theta - estimate)

    assert result.data_cost == pytest.approx(distance(result.theta), rel=1e-6)
    candidates = [robot_2r.base_values] + [
        robot_2r.base.values(_random_robot(robot_2r, rng)) for _ in range(30)
    ]
    assert all(result.data_cost <= distance(c) * (1 + 1e-6) for c in candidates)
    assert "FV1 >= 0" in result.active


def test_bad_arguments(robot_2r):
    W = _rows(robot_2r, 1, samples=50)
    tau = W @ robot_2r.base_values
    with pytest.raises(ValueError, match=r"W must have shape \(N, n, 8\)"):
        solve_physical(robot_2r, W[..., :5], tau)
    with pytest.raises(ValueError, match="regularization must be >= 0"):
        solve_physical(robot_2r, W, tau, regularization=-1.0)
    with pytest.raises(ValueError, match="W must be finite"):
        solve_physical(robot_2r, W * np.nan, tau)
    with pytest.raises(ValueError, match="covariance must be symmetric"):
        project_physical(robot_2r, robot_2r.base_values, np.triu(np.ones((8, 8))))
    with pytest.raises(ValueError, match="positive semidefinite"):
        project_physical(robot_2r, robot_2r.base_values, -np.eye(8))
    # A noise-free fit (σ̂ = 0) stays solvable and exact.
    result = solve_physical(robot_2r, W, tau)
    np.testing.assert_allclose(result.theta, robot_2r.base_values, rtol=1e-6)


def test_a_failed_solve_says_it_once_and_prints_nothing_else(capfd, caplog):
    """Found by a review: SCS's log line (``SCS returns code -2``) and its C
    ``WARNING - large complementary slackness residual`` reached the terminal
    beside the error. θ: the 2R fit of a log whose ns stamps were read as seconds
    (h = 1e6 s)."""
    import logging

    theta = [7.997486e11, -3.203678e11, 2.295677e12, -4.040246e11, 3.943860e7]
    theta += [-0.3527695, -7.342464e5, 0.1836887]
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    capfd.readouterr()
    with caplog.at_level(logging.INFO), pytest.raises(ValueError, match="SCS: "):
        check_physical(robot, theta)
    out, err = capfd.readouterr()
    assert out == "" and err == "", (out, err)
    assert not [r for r in caplog.records if r.name.startswith("drake")]
    print("still printed")  # the standard output is restored
    assert capfd.readouterr().out == "still printed\n"


def test_a_physical_check_that_cannot_be_solved_does_not_stop_offline(
    tmp_path, capsys, monkeypatch
):
    """The check nobody asked for: reported as not done, the JSON still written."""
    from _motions import fourier_2r

    from drake_dynid import cli, physical
    from drake_dynid.logs import write_log

    robot, t, q, tau = fourier_2r(20001)
    write_log(tmp_path / "log.csv", t, q, tau, robot.joint_names)

    def unsolvable(*args, **kwargs):
        raise ValueError("check_physical: the semidefinite program could not be solved")

    monkeypatch.setattr(physical, "check_physical", unsolvable)
    out = tmp_path / "fit.json"
    argv = ["offline", str(tmp_path / "log.csv"), "--urdf", model_path("planar_2r")]
    assert cli.main([*argv, "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "physical check of the estimate: not done (check_physical: " in printed
    check = json.loads(out.read_text())["physical_check"]
    assert check["consistent"] is None and check["summary"].startswith("not done")


def test_an_estimate_far_from_the_urdfs_scale_is_still_checked():
    """Found by a review: torques logged in mN·m (θ 1e4 times the URDF's) made the
    feasibility program infeasible (its box was ±1e4 scale units around the URDF)
    and stopped dynid offline. A consistent robot scaled by 1e6 is consistent."""
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    check = check_physical(robot, 1e6 * robot.base_values)
    assert check.consistent, check.summary()


def test_the_box_grows_only_for_an_estimate_in_another_unit():
    """A review found the TIAGo's arm_6_link verdict changed when the box grew
    with any estimate far from the URDF: only a unit factor (median >= 100)
    widens it."""
    from drake_dynid.physical import _unit_scale

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    theta = robot.base_values.copy()
    assert _unit_scale(robot, 6.8 * theta) == 1.0
    theta[0] *= 1e6  # one wild parameter
    assert _unit_scale(robot, theta) == 1.0
    assert _unit_scale(robot, 1e4 * robot.base_values) == pytest.approx(1e4)


def test_an_impossible_estimate_names_the_physical_option(capsys):
    """A review: the 'physically impossible' line did not say what to do."""
    from drake_dynid.commands._model import consistency
    from drake_dynid.plants import RobotModel, model_path

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    theta = np.array(robot.base_values, dtype=float)
    theta[list(robot.base_names).index("FV1")] = -0.1
    entry = consistency(robot, theta, False, "the estimate", hint=True)
    out = capsys.readouterr().out
    assert entry["consistent"] is False and "FV1" in entry["negative"]
    assert "physically impossible" in out and "--physical gives the closest" in out
    consistency(robot, theta, False, "the estimate", hint=False)
    assert "--physical" not in capsys.readouterr().out


def _weak_iiwa_rows(iiwa, seed=6, samples=40, noise=0.05):
    """40 random rows of the iiwa7 (few for 57 base parameters: weak excitation)
    and torques of its URDF robot with noise."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (samples, iiwa.num_joints))
    v, vdot = rng.normal(size=(2, samples, iiwa.num_joints))
    W = iiwa.idim_rows(q, v, vdot)
    return W, W @ iiwa.base_values + noise * rng.normal(size=W.shape[:2])


def test_the_entropic_regularizer_keeps_a_link_the_euclidean_one_empties(iiwa):
    """Found by a review: the euclidean pull costs at most λ·O(1) to empty a link,
    and the noisy data of a weakly excited link 7 buy that (iiwa_link_7 at
    8.9e-6 of its URDF mass, its pseudo-inertia on the boundary). The log-det
    divergence is infinite at a singular J: the link keeps 15 % of its mass and
    J ≻ 0, for the same data cost (+0.005 residual variances)."""
    W, tau = _weak_iiwa_rows(iiwa)
    mass = [f"M{j + 1}" for j in range(iiwa.num_joints)]
    urdf = np.array([iiwa.standard_parameters()[m] for m in mass])
    euclidean = solve_physical(iiwa, W, tau)
    entropic = solve_physical(iiwa, W, tau, regularizer="entropic")
    assert euclidean.regularizer == "euclidean" and entropic.regularizer == "entropic"
    # λ = 0 is one program, the euclidean one, and is recorded so (it said
    # "entropic"; helper-79's review).
    free = solve_physical(iiwa, W, tau, regularization=0.0, regularizer="entropic")
    assert free.regularizer == "euclidean"
    emptied = euclidean.standard_parameters()["M7"] / urdf[-1]
    assert emptied < 1e-3 and "J(iiwa_link_7) ⪰ 0" in euclidean.active
    kept = np.array([entropic.standard_parameters()[m] for m in mass]) / urdf
    assert kept.min() > 0.1, kept
    assert entropic.link_min_eigenvalues.min() > 1e-5  # 10 times the margin
    assert not [a for a in entropic.active if a.startswith("J(")]
    assert entropic.data_cost < euclidean.data_cost + 0.05
    assert check_physical(iiwa, entropic.theta).consistent


def _entropic_objective(robot, W, tau, standard, regularization, logdets=None):
    """(‖Wθ − τ‖² − ρ²)/σ̂² + λ Σ_j d(K_j, P_j) + λ‖x − x₀‖² (friction), as
    documented: d(K, P) = −log det K + log det P + tr(P⁻¹K) − 4, K_j the scaled
    pseudo-inertia T_j J_j T_j (the divergence is congruence-invariant, so with
    J_j itself and the URDF's J_j,0). ``logdets``: log det J_j when known (from a
    Cholesky factor)."""
    scales, _, _ = parameter_scales(robot)
    divergence = 0.0
    for j in range(robot.num_joints):
        J = pseudo_inertia(standard[10 * j : 10 * j + 10])
        J0 = pseudo_inertia(robot.standard_values[10 * j : 10 * j + 10])
        if logdets is None:
            sign, logdet = np.linalg.slogdet(J)
            if sign <= 0:
                return np.inf
        else:
            logdet = logdets[j]
        divergence += (
            -logdet + np.linalg.slogdet(J0)[1] + np.trace(np.linalg.solve(J0, J)) - 4
        )
    other = slice(10 * robot.num_joints, None)
    prior = (standard[other] - robot.standard_values[other]) / scales[other]
    data = _data_cost(robot, W, tau, standard)
    return data + regularization * (divergence + prior @ prior)


def test_the_entropic_fit_is_the_optimum_of_the_documented_problem(robot_2r):
    # Torques of a non-physical 2R (ZZ2 < 0, FC2 < 0) with noise; a local
    # optimiser over J = L Lᵀ (friction z²) from the URDF finds nothing better.
    W = _rows(robot_2r, 2)
    theta = robot_2r.base_values.copy()
    theta[1] = -0.05
    theta[7] = -0.1
    tau = W @ theta + 0.05 * np.random.default_rng(3).normal(size=W.shape[:2])
    result = solve_physical(
        robot_2r, W, tau, regularization=1e-2, regularizer="entropic"
    )
    assert check_physical(robot_2r, result.theta).consistent
    assert result.link_min_eigenvalues.min() > 1e-6
    sdp = _entropic_objective(robot_2r, W, tau, result.standard_values, 1e-2)
    start = _to_cholesky(robot_2r)
    diagonal = [10 * j + k for j in range(2) for k in (0, 2, 5, 9)]  # L_ii

    def objective(z):
        logdets = 2.0 * np.log(np.abs(z[diagonal])).reshape(2, 4).sum(axis=1)
        standard = _from_cholesky(robot_2r, z)
        return _entropic_objective(robot_2r, W, tau, standard, 1e-2, logdets)

    local = optimize.minimize(
        objective,
        start,
        method="BFGS",
        options={"gtol": 1e-9, "maxiter": 5000},
    )
    assert sdp <= local.fun + 1e-4 * abs(local.fun) + 1e-4
    # Data the URDF robot fits exactly: the divergence's minimum, the URDF itself
    # (to the solver's 9e-4 on MX1, which the data do not see).
    exact = solve_physical(
        robot_2r, W, W @ robot_2r.base_values, regularizer="entropic"
    )
    np.testing.assert_allclose(
        exact.standard_values, robot_2r.standard_values, rtol=2e-3, atol=1e-5
    )


def test_an_unknown_regularizer_is_refused_by_name(robot_2r):
    W = _rows(robot_2r, 1, samples=50)
    tau = W @ robot_2r.base_values
    message = "regularizer must be one of 'euclidean', 'entropic'; got 'logdet'"
    with pytest.raises(ValueError, match=message):
        solve_physical(robot_2r, W, tau, regularizer="logdet")
    with pytest.raises(ValueError, match=message):
        solve_physical_reduced(robot_2r, reduce_rows(W, tau), regularizer="logdet")
    with pytest.raises(ValueError, match=message):
        project_physical(
            robot_2r, robot_2r.base_values, np.eye(8), regularizer="logdet"
        )
    with pytest.raises(ValueError, match="regularizer must be one of"):
        solve_physical(robot_2r, W, tau, regularizer=None)
