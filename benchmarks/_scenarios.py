"""The 2R scenarios of the accuracy benchmark: geometries and trajectories.

``robots``: the paper's 2R and two variants (URDFs generated in a directory from
planar_2r.urdf: ``g1`` L1 = 0.7 m, heavy link 2, strong friction; ``g2`` L1 = 1.3 m,
light link 2, weak friction); ``scenarios``: the trajectories run on them
(``random_fourier_trajectory``: H = 5, ω_f = 2π·0.1, |q̇| <= 4 rad/s,
default_rng(1|2|3), and the wide-band H = 4, ω_f = 2π·0.25, default_rng(5)).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from drake_dynid import paper
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.robot import RobotModel
from drake_dynid.urdf import model_path


def _variant(text: str, L1, m1, izz1, m2, com2, izz2, fv, fc) -> str:
    """planar_2r.urdf with another geometry, masses and friction."""

    def sub(pattern, value, t):
        return re.sub(pattern, lambda m: m.group(1) + value, t, count=1, flags=re.S)

    inertia = 'ixx="{a}" ixy="0" ixz="0" iyy="{b}" iyz="0" izz="{b}"'
    t = sub(r'(<link name="link1">.*?<origin xyz=")[^"]*', f"{L1 / 2} 0 0", text)
    t = sub(r'(<link name="link1">.*?<mass value=")[^"]*', f"{m1}", t)
    t = sub(
        r'(<link name="link1">.*?<inertia )[^/]*',
        inertia.format(a=0.05 * izz1, b=izz1),
        t,
    )
    t = sub(r'(<link name="link2">.*?<origin xyz=")[^"]*', f"{com2[0]} {com2[1]} 0", t)
    t = sub(r'(<link name="link2">.*?<mass value=")[^"]*', f"{m2}", t)
    t = sub(
        r'(<link name="link2">.*?<inertia )[^/]*',
        inertia.format(a=0.05 * izz2, b=izz2),
        t,
    )
    t = sub(r'(<joint name="joint2".*?<origin xyz=")[^"]*', f"{L1} 0 0", t)
    for j in (0, 1):
        t = sub(
            rf'(<joint name="joint{j + 1}".*?<dynamics )[^/]*',
            f'damping="{fv[j]}" friction="{fc[j]}"',
            t,
        )
    return t


def robots(directory: Path) -> dict[str, RobotModel]:
    text = Path(model_path("planar_2r")).read_text()
    g1 = _variant(text, 0.7, 3.0, 1.5, 2.0, (0.3, -0.05), 0.05, (0.5, 0.2), (0.6, 0.3))
    g2 = _variant(text, 1.3, 1.0, 0.8, 0.5, (0.6, 0.08), 0.02, (0.1, 0.05), (0.2, 0.1))
    (directory / "g1.urdf").write_text(g1)
    (directory / "g2.urdf").write_text(g2)
    return {
        "paper": RobotModel.from_urdf(model_path("planar_2r")),
        "g1": RobotModel.from_urdf(directory / "g1.urdf"),
        "g2": RobotModel.from_urdf(directory / "g2.urdf"),
    }


def _rf(seed: int, harmonics: int = 5, f: float = 0.1):
    return random_fourier_trajectory(
        2,
        harmonics=harmonics,
        base_frequency=2 * np.pi * f,
        max_velocity=4.0,
        rng=np.random.default_rng(seed),
    )


def scenarios(quick: bool) -> dict[str, tuple[str, object]]:
    main = {"paper 2R / paper_trajectory": ("paper", paper.paper_trajectory())}
    if quick:
        return main
    return {
        **main,
        "g1 / paper_trajectory": ("g1", paper.paper_trajectory()),
        "g2 / paper_trajectory": ("g2", paper.paper_trajectory()),
        "paper 2R / rf seed 1": ("paper", _rf(1)),
        "paper 2R / rf seed 2": ("paper", _rf(2)),
        "g1 / rf seed 3": ("g1", _rf(3)),
        "paper 2R / wide rf seed 5": ("paper", _rf(5, harmonics=4, f=0.25)),
    }
