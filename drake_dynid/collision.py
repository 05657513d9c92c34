"""Self-collision clearance of a URDF robot, from Drake's SceneGraph.

``SelfCollision.from_urdf`` loads the robot with a SceneGraph (its ``<collision>``
geometry) and answers, for a batch of configurations, the smallest signed distance
between two collision geometries of the robot::

    d(q) = min over checked pairs (A, B) of signed_distance(A, B)   [m]

(negative when they penetrate), from ``QueryObject.
ComputeSignedDistancePairwiseClosestPoints``. Pairs the plant filters (bodies
connected by a joint) are never reported; pairs already in contact at the reference
configuration (the middle of the position limits; coarse meshes of neighbouring
links often overlap there) are ignored, as MoveIt's "default in collision" pairs.
A URDF without collision geometry gives None (nothing to check).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from drake_dynid.urdf import JointEmbedding

__all__ = ["SelfCollision"]

#: Distances beyond this are not computed [m]; d(q) is capped at it.
MAX_DISTANCE = 1.0
#: A pair closer than the margin at the reference is held no closer than this
#: fraction of its distance there.
HELD = 0.5


class SelfCollision:
    """Callable ``q (M, n) -> d (M,)``: smallest signed distance per configuration.

    Holds a Drake diagram (plant + SceneGraph) and one Context, so it is not
    thread-safe. Build it with :meth:`from_urdf`.

    Attributes:
        num_geometries: collision geometries of the robot.
        ignored: names of the pairs ignored (in contact at the reference).
        held: "pair (distance m)" of the pairs closer than the margin at the
            reference (that distance), held no closer than ``HELD`` (half) of it.
    """

    def __init__(
        self,
        diagram: Any,
        plant: Any,
        scene_graph: Any,
        q_reference,
        embedding: JointEmbedding | None = None,
        margin: float = 0.0,
    ):
        for name, value in (("diagram", diagram), ("scene_graph", scene_graph)):
            if not hasattr(
                value,
                "CreateDefaultContext" if name == "diagram" else "model_inspector",
            ):
                raise TypeError(
                    f"SelfCollision: {name} must be a Drake {name}; got "
                    f"{type(value).__name__} (use SelfCollision.from_urdf)."
                )
        self._diagram = diagram
        self._plant = plant
        self._embedding = embedding
        self._scene_graph = scene_graph
        self._context = diagram.CreateDefaultContext()
        self._plant_context = plant.GetMyMutableContextFromRoot(self._context)
        self._sg_context = scene_graph.GetMyContextFromRoot(self._context)
        inspector = scene_graph.model_inspector()
        self.num_geometries = len(inspector.GetAllGeometryIds())
        self._ignored: set[tuple[Any, Any]] = set()
        # A pair closer than the margin at the reference (the SO-101's jaw 9.4 mm
        # from its wrist, the Talos' gripper links 0.7 mm apart: no design could
        # start) is held no closer than half its distance there: its distance
        # counts margin - d_reference/2 more. Held at d_reference itself, the
        # reference sat on the bound and any motion about it brought the pair
        # closer at some instant (the SO-101: 29 of 80 samples at 1e-4 of the
        # start's amplitude), so the design's start shrunk out of collision
        # was a standstill.
        self._offset: dict[tuple[Any, Any], float] = {}
        reference: dict[tuple[Any, Any], float] = {}
        for pair in self._pairs(np.asarray(q_reference, dtype=float)):
            if pair.distance < 0.0:
                self._ignored.add(self._key(pair))
            elif pair.distance < margin:
                self._offset[self._key(pair)] = margin - HELD * pair.distance
                reference[self._key(pair)] = pair.distance
        self.ignored = tuple(sorted(self._describe(a, b) for a, b in self._ignored))
        self.held = tuple(
            f"{self._describe(a, b)} ({d:.2g} m)"
            for (a, b), d in sorted(reference.items(), key=lambda i: -i[1])
        )

    @classmethod
    def from_urdf(
        cls, path: str | Path, q_reference: Any, robot: Any = None, margin: float = 0.0
    ) -> SelfCollision | None:
        """Loads the URDF with a SceneGraph; None if it has no collision geometry.

        Args:
            path: the URDF.
            q_reference: (n,) configuration whose contacts are ignored [rad or m].
            robot: the ``RobotModel`` whose joints q holds (``joint_names``, in
                that order); the URDF's other joints at their ``locked``
                positions, its mimic joints following their leaders. None: q is
                the plant's whole position vector.
            margin: the clearance the design keeps [m]; a pair closer than it at
                q_reference (not in contact) is held no closer than half its
                reference distance (``held``): its distance is reported
                ``margin - d_reference/2`` larger.
        """
        from pydrake.geometry import Role
        from pydrake.systems.framework import DiagramBuilder

        from drake_dynid.urdf import load_plant

        builder = DiagramBuilder()
        plant = load_plant(path, builder=builder, geometry="collision")
        scene_graph = next(
            s for s in builder.GetSystems() if s.get_name() == "scene_graph"
        )
        inspector = scene_graph.model_inspector()
        if inspector.NumGeometriesWithRole(Role.kProximity) == 0:
            return None
        embedding = None
        if robot is not None:
            embedding = _embedding(plant, robot)
            _exclude_rigid_pairs(plant, scene_graph, robot)
        return cls(builder.Build(), plant, scene_graph, q_reference, embedding, margin)

    @staticmethod
    def _key(pair: Any) -> tuple[Any, Any]:
        a, b = pair.id_A, pair.id_B
        return (a, b) if a.get_value() < b.get_value() else (b, a)

    def _pairs(self, q: np.ndarray) -> list[Any]:
        if self._embedding is not None:  # the identified joints in the whole plant
            q = self._embedding.place(q)
        self._plant.SetPositions(self._plant_context, q)
        query = self._scene_graph.get_query_output_port().Eval(self._sg_context)
        return query.ComputeSignedDistancePairwiseClosestPoints(MAX_DISTANCE)

    def _describe(self, a: Any, b: Any) -> str:
        inspector = self._scene_graph.model_inspector()
        bodies = [
            self._plant.GetBodyFromFrameId(inspector.GetFrameId(g)).name()
            for g in (a, b)
        ]
        return f"{bodies[0]}-{bodies[1]}"

    def __call__(self, q: Any) -> np.ndarray:
        """Smallest signed distance [m] (capped at MAX_DISTANCE) for each row of q."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        out = np.full(q.shape[0], MAX_DISTANCE)
        for k in range(q.shape[0]):
            best = MAX_DISTANCE
            for pair in self._pairs(q[k]):
                # The offsets are > 0: a pair no closer than the best so far is
                # skipped before its (slow) key (the SO-101: 85 pairs a configuration,
                # the key's two get_value calls a fifth of the clearance's time).
                distance = pair.distance
                if distance < best:
                    key = self._key(pair)
                    if key not in self._ignored:
                        best = min(best, distance + self._offset.get(key, 0.0))
            out[k] = best
        return out

    def closest(self, q: Any) -> tuple[float, str]:
        """(distance [m], "bodyA-bodyB") of the closest checked pair at one q."""
        best, name = MAX_DISTANCE, ""
        for pair in self._pairs(np.asarray(q, dtype=float)):
            key = self._key(pair)
            distance = pair.distance + self._offset.get(key, 0.0)
            if distance < best and key not in self._ignored:
                best, name = distance, self._describe(pair.id_A, pair.id_B)
        return float(best), name

    def below(self, q: Any, margin: float) -> list[tuple[float, str, float]]:
        """Every checked pair closer than ``margin`` [m] at one q, closest first.

        [(distance [m], "bodyA-bodyB", geometric distance [m])], the distances as
        :meth:`closest`'s (a held pair's with its offset), then the pair's own
        signed distance (a held pair breaks the margin when it is closer than half
        its reference distance).
        """
        out = []
        for pair in self._pairs(np.asarray(q, dtype=float)):
            key = self._key(pair)
            distance = pair.distance + self._offset.get(key, 0.0)
            if distance < margin and key not in self._ignored:
                name = self._describe(pair.id_A, pair.id_B)
                out.append((float(distance), name, float(pair.distance)))
        return sorted(out)


def _embedding(plant: Any, robot: Any) -> JointEmbedding:
    """The identified joints' q placed in ``plant``'s position vector.

    ``urdf.joint_embedding``: the locked joints at their values, the mimic joints
    following their leaders.
    """
    from drake_dynid.urdf import joint_embedding

    return joint_embedding(
        plant,
        robot.joint_names,
        dict(getattr(robot, "locked", {})),
        dict(getattr(robot, "mimic", {})),
    )


def _exclude_rigid_pairs(plant: Any, scene_graph: Any, robot: Any) -> None:
    """Filters the pairs whose distance no identified joint changes.

    Bodies joined by joints that do not move (locked, fixed) form rigid groups;
    two geometries of one group keep their distance whatever q is, so the check
    never needs it. The TIAGo's or Talos' arm with the rest of the robot locked:
    on talos_reduced.urdf (left arm, 52 collision geometries) 1167 pairs were
    computed per configuration (5.3 ms), most of them between the locked legs,
    torso, head and right arm (now 659, 2.4 ms). A mimic joint moves with its
    leader.
    """
    from pydrake.geometry import CollisionFilterDeclaration, GeometrySet
    from pydrake.multibody.tree import BodyIndex

    moving = set(robot.joint_names)
    moving |= {
        name
        for name, (leader, *_) in dict(getattr(robot, "mimic", {})).items()
        if leader in moving
    }
    bodies = [plant.get_body(BodyIndex(k)) for k in range(plant.num_bodies())]
    group = list(range(len(bodies)))

    def root(k: int) -> int:
        while group[k] != k:
            group[k] = group[group[k]]
            k = group[k]
        return k

    for index in plant.GetJointIndices():
        joint = plant.get_joint(index)
        if joint.name() in moving and joint.num_velocities() > 0:
            continue
        a = root(int(joint.parent_body().index()))
        b = root(int(joint.child_body().index()))
        group[a] = b
    members: dict[int, list[Any]] = {}
    for body in bodies:
        ids = plant.GetCollisionGeometriesForBody(body)
        if ids:
            members.setdefault(root(int(body.index())), []).extend(ids)
    manager = scene_graph.collision_filter_manager()
    for ids in members.values():
        if len(ids) > 1:
            manager.Apply(CollisionFilterDeclaration().ExcludeWithin(GeometrySet(ids)))
