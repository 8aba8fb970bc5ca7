"""Narrow phase with coal: one contact (depth, normal, point) per colliding pair.

Per pair (robot piece, terrain part) or (piece a, piece b) coal's GJK/EPA gives the
penetration depth d = −penetration_depth > 0 and the normal n from shape 1 towards
shape 2. One contact per pair, at:

  * shape–shape pairs (half-spaces, two robot pieces): the centroid (vertex mean) of
    coal's contact patch, the polygon where the two shapes' supports in the normal
    direction meet (within coal's 1 mm patch tolerance). A cylinder lying on a plane
    gets the middle of its contact line, a box on a face the middle of the face: a
    single penalty force there has the right moment (coal's bare witness point is a
    corner). A tilted body's patch is its lowest point.
  * piece–triangle-mesh pairs: coal reports one contact per intersecting triangle
    (up to ``max_contacts``); the pair's contact takes the deepest one's depth and
    normal, at the depth-weighted mean of their points. Counting each triangle as a
    contact would make the force depend on the triangulation.

The point is coal's mid-point between the two surfaces (half the depth from each).
Loops here run over colliding pairs (a Python call into coal each), after the
component's vectorised bounding-sphere culling.
"""

from __future__ import annotations

import numpy as np


class Narrowphase:
    def __init__(self, max_contacts: int = 8):
        import coal

        self._coal = coal
        self.req = coal.CollisionRequest()
        self.req.enable_contact = True
        self.req.num_max_contacts = int(max_contacts)
        self.req.security_margin = 0.0
        self.preq = coal.ContactPatchRequest()
        self.res = coal.CollisionResult()
        self.pres = coal.ContactPatchResult(self.preq)

    def collide(self, g1, T1, g2, T2, triangles: bool):
        """-> (depth, normal from g1 to g2 (3,), point (3,)) or None when apart."""
        coal, res = self._coal, self.res
        res.clear()
        if not coal.collide(g1, T1, g2, T2, self.req, res):
            return None
        if triangles:
            cs = res.getContacts()
            d = np.array([-c.penetration_depth for c in cs])
            if d.max() <= 0.0:
                return None
            k = int(np.argmax(d))
            w = np.maximum(d, 0.0)
            pts = np.array([c.pos for c in cs])
            return float(d[k]), np.array(cs[k].normal), (w[:, None] * pts).sum(0) / w.sum()
        c = res.getContact(0)
        depth = -c.penetration_depth
        if depth <= 0.0:
            return None
        self.pres.clear()
        coal.computeContactPatch(g1, T1, g2, T2, res, self.preq, self.pres)
        if self.pres.numContactPatches():
            patch = self.pres.getContactPatch(0)
            m = patch.size()
            point = sum(patch.getPoint(i) for i in range(m)) / m if m else np.array(c.pos)
        else:
            point = np.array(c.pos)
        return float(depth), np.array(c.normal), point
