"""Self-collision truth on the collision meshes themselves, independent of ferrobot's geometry
code: Pinocchio's URDF geometry loader (meshes as coal BVH triangle models, not hulls) and coal's
mesh-mesh distance, with link poses from Pinocchio's own FK. Shared by
tests/test_robots_in_env.py and benches/self_collision_meshes.py."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import robots_in_env as env


class MeshTruth:
    """Distances between the collision meshes of the link pairs a ferrobot checker checks."""

    def __init__(self, name: str, model, checker):
        urdf = env.urdf_path(name)
        self.pm = pin.buildModelFromUrdf(str(urdf))
        pkg = [str(env.ERD.parent.parent)] if env.ERD is not None else []
        self.gm = pin.buildGeomFromUrdf(self.pm, str(urdf), pin.COLLISION, package_dirs=pkg)
        self.data = self.pm.createData()
        self.gdata = pin.GeometryData(self.gm)
        allowed = {frozenset((a, b)) for a, b, _ in checker.allowed_collision_pairs}
        link_of = [self.pm.frames[g.parentFrame].name for g in self.gm.geometryObjects]
        self.pairs = [
            (i, j, link_of[i], link_of[j])
            for i in range(len(link_of))
            for j in range(i + 1, len(link_of))
            if link_of[i] != link_of[j] and frozenset((link_of[i], link_of[j])) not in allowed
        ]
        self.dof = list(model.dof_names)

    def to_pin(self, q: np.ndarray) -> np.ndarray:
        out = np.zeros(self.pm.nq)
        for jid in range(1, self.pm.njoints):
            idx, nq = self.pm.idx_qs[jid], self.pm.nqs[jid]
            v = q[self.dof.index(self.pm.names[jid])]
            if nq == 2:
                out[idx : idx + 2] = [np.cos(v), np.sin(v)]
            elif nq == 1:
                out[idx] = v
        return out

    def min_distance(self, q: np.ndarray) -> tuple[float, str]:
        """The smallest mesh-mesh distance over the checked pairs (m; 0 when touching or
        intersecting) and the pair it is on."""
        pin.updateGeometryPlacements(self.pm, self.data, self.gm, self.gdata, self.to_pin(q))
        best, which = np.inf, ""
        req, res = coal.DistanceRequest(), coal.DistanceResult()
        creq, cres = coal.CollisionRequest(), coal.CollisionResult()
        for i, j, a, b in self.pairs:
            ga, gb = self.gm.geometryObjects[i], self.gm.geometryObjects[j]
            pa, pb = self.gdata.oMg[i], self.gdata.oMg[j]
            cres.clear()
            if coal.collide(ga.geometry, pa, gb.geometry, pb, creq, cres):
                d = 0.0
            else:
                res.clear()
                d = coal.distance(ga.geometry, pa, gb.geometry, pb, req, res)
            if d < best:
                best, which = max(d, 0.0), f"{a}-{b}"
        return float(best), which
