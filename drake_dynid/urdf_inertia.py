"""Non-physical ``<inertial>`` elements of a URDF (pure XML and numpy).

Drake's parser replaces an inertia it cannot accept (a mass <= 0, principal
moments that are negative or break the triangle inequality λ_i + λ_j >= λ_k) by
a default (the solid sphere of water density of that mass, or of 1 kg), warns
without naming the link, and loads the rest. The robot's standard parameters then
hold Drake's values, not the file's: :func:`inertia_note` names each link whose
inertia the loaded plant does not hold as written (compared body by body: mass
and central principal moments) and what is wrong with it, so that ``dynid
params`` and every command say it (``RobotModel.notes``, one ``note:`` line on
stderr).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from drake_dynid.core._validate import listed

__all__ = ["inertia_note", "nonphysical_inertias", "substituted_inertias"]

_RELATIVE = 1e-9  # tolerance of the checks, relative to the largest moment


def _number(element: Any, name: str) -> float:
    try:
        return float(element.attrib.get(name, "0"))
    except ValueError:
        return math.nan


def nonphysical_inertias(root: Any) -> list[tuple[str, str]]:
    """``[(link, what is wrong)]`` for every link whose ``<inertial>`` Drake rejects.

    Args:
        root: the URDF's parsed root element (``xml.etree.ElementTree``).
    """
    out = []
    for link in root.iter("link"):
        inertial = link.find("inertial")
        name = link.attrib.get("name", "?")
        if inertial is None or name == "world":
            continue
        mass_element = inertial.find("mass")
        mass = _number(mass_element, "value") if mass_element is not None else 0.0
        inertia = inertial.find("inertia")
        moments = np.zeros(3)
        if inertia is not None:
            i = {
                k: _number(inertia, k)
                for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
            }
            matrix = np.array(
                [
                    [i["ixx"], i["ixy"], i["ixz"]],
                    [i["ixy"], i["iyy"], i["iyz"]],
                    [i["ixz"], i["iyz"], i["izz"]],
                ]
            )
            if not np.all(np.isfinite(matrix)):
                out.append((name, "a non-finite inertia"))
                continue
            moments = np.linalg.eigvalsh(matrix)
        if not math.isfinite(mass) or mass < 0.0:
            out.append((name, f"mass {mass:g} kg < 0"))
            continue
        scale = max(float(np.max(np.abs(moments))), 1e-300)
        if mass == 0.0:
            if scale > 1e-300:
                out.append((name, "mass 0 kg with a non-zero inertia"))
            continue
        text = ", ".join(f"{m:.4g}" for m in moments)
        if moments[0] < -_RELATIVE * scale:
            out.append((name, f"principal moments {text} kg·m², one negative"))
        elif moments[0] + moments[1] < moments[2] - _RELATIVE * scale:
            out.append(
                (name, f"principal moments {text} kg·m² break the triangle inequality")
            )
    return out


def _file_inertias(root: Any) -> dict[str, tuple[float, np.ndarray]]:
    """Link -> (mass, central principal moments) as written in the file."""
    out = {}
    for link in root.iter("link"):
        inertial = link.find("inertial")
        name = link.attrib.get("name", "?")
        if inertial is None or name == "world":
            continue
        mass_element = inertial.find("mass")
        mass = _number(mass_element, "value") if mass_element is not None else 0.0
        inertia = inertial.find("inertia")
        values = {
            k: _number(inertia, k) if inertia is not None else 0.0
            for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
        }
        matrix = np.array(
            [
                [values["ixx"], values["ixy"], values["ixz"]],
                [values["ixy"], values["iyy"], values["iyz"]],
                [values["ixz"], values["iyz"], values["izz"]],
            ]
        )
        if np.all(np.isfinite(matrix)):
            out[name] = (mass, np.linalg.eigvalsh(matrix))
        else:
            out[name] = (mass, np.full(3, np.nan))
    return out


def substituted_inertias(root: Any, plant: Any) -> list[tuple[str, str]]:
    """``[(link, why)]``: the links whose inertia ``plant`` does not hold as written.

    Each body of the (finalized or not) plant named like a URDF link is compared
    with the file: its mass and the principal moments of its central rotational
    inertia, to 1e-6 relative. ``why`` is what :func:`nonphysical_inertias`
    found wrong, else the values Drake holds.
    """
    reasons = dict(nonphysical_inertias(root))
    out = []
    for name, (mass, moments) in _file_inertias(root).items():
        if not plant.HasBodyNamed(name):
            continue
        body = plant.GetBodyByName(name)
        spatial = body.default_spatial_inertia()
        held_mass = float(spatial.get_mass())
        central = spatial.Shift(spatial.get_com())  # about the centre of mass
        held = central.CalcRotationalInertia().CopyToFullMatrix3()
        held_moments = np.linalg.eigvalsh(np.asarray(held))
        # Round-off scale: the moments, or 1 mm² times the mass (a zero inertia).
        scale = max(float(np.max(np.abs(held_moments))), abs(held_mass) * 1e-6, 1e-300)
        same_mass = math.isfinite(mass) and abs(held_mass - mass) <= 1e-6 * max(
            abs(mass), 1e-300
        )
        same_moments = bool(
            np.all(np.isfinite(moments))
            and np.all(np.abs(held_moments - moments) <= 1e-6 * scale + 1e-300)
        )
        if same_mass and same_moments:
            continue
        why = reasons.get(name) or (
            f"mass {mass:g} kg and principal moments "
            f"{', '.join(f'{m:.4g}' for m in moments)} kg·m² in the file"
        )
        out.append(
            (
                name,
                f"{why}; Drake holds mass {held_mass:.4g} kg, principal moments "
                f"{', '.join(f'{m:.4g}' for m in held_moments)} kg·m²",
            )
        )
    return out


def inertia_note(root: Any, plant: Any, file_name: str) -> str | None:
    """One note naming the links of :func:`substituted_inertias`, or None."""
    bad = substituted_inertias(root, plant)
    if not bad:
        return None
    links = listed((f"link {name!r}: {what}" for name, what in bad), sep="; ")
    return (
        f"non-physical <inertial> in {file_name} ({links}): Drake's parser replaced "
        "these inertias (by a solid sphere of the mass, of 1 kg when the mass is "
        "not positive), so the standard parameters of these links, and anything "
        "simulated with them, are Drake's values, not the file's: fix the URDF"
    )
