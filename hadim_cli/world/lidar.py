"""LIDAR: analytic ray casting against the room's walls and circular objects.

Ray k leaves the robot's centre at angle heading + 2πk/n; its range is the distance to the
first wall or object surface, clipped to the sensor's range. The robot never sees itself.

Plain Python on purpose: with 16 rays and 9 objects, numpy's per-call overhead costs more than
the arithmetic, and an object is only tested against the few rays inside its angular extent
(none when it is out of range), which a dense rays × objects matrix cannot skip.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

_PARALLEL = 1e-12  # a direction component below this never reaches that pair of walls


class Lidar:
    """A ring of `n_rays` rays of range `max_range` in a room of half-size (half_w, half_h)."""

    def __init__(self, n_rays: int, max_range: float, half_w: float, half_h: float):
        self.n_rays = n_rays
        self.max_range = max_range
        self.half_w = half_w
        self.half_h = half_h
        self._step = 2 * math.pi / n_rays
        self._base = [(math.cos(self._step * k), math.sin(self._step * k))
                      for k in range(n_rays)]

    def directions(self, heading: float) -> list[tuple[float, float]]:
        """Unit (dx, dy) of every ray in the room frame."""
        ch, sh = math.cos(heading), math.sin(heading)
        return [(ch * c - sh * s, sh * c + ch * s) for c, s in self._base]

    def _walls(self, x: float, y: float, dirs: list[tuple[float, float]]) -> list[float]:
        """Distance along each ray to the wall it points to, at most the range."""
        east, west = self.half_w - x, -self.half_w - x
        north, south = self.half_h - y, -self.half_h - y
        reach, inf = self.max_range, math.inf
        out = []
        for dx, dy in dirs:
            tx = east / dx if dx > _PARALLEL else west / dx if dx < -_PARALLEL else inf
            ty = north / dy if dy > _PARALLEL else south / dy if dy < -_PARALLEL else inf
            t = tx if tx < ty else ty
            out.append(t if t < reach else reach)
        return out

    def ranges(self, x: float, y: float, heading: float, centers: Iterable[Sequence[float]],
               radii: Iterable[float]) -> list[float]:
        """Range of every ray (m) from (x, y), given the objects' centres and radii."""
        dirs = self.directions(heading)
        out = self._walls(x, y, dirs)
        n, step, reach = self.n_rays, self._step, self.max_range
        for (cx, cy), r in zip(centers, radii, strict=True):
            rx, ry = cx - x, cy - y
            d2 = rx * rx + ry * ry
            if d2 >= (reach + r) * (reach + r):
                continue  # out of range
            c = d2 - r * r
            if c <= 0.0:
                return [0.0] * n  # inside an object: cannot happen with solid bodies
            # Rays within the object's angular half-extent asin(r/d) of its bearing; one more
            # on each side so rounding never drops a grazing ray (the disc test decides).
            bearing = (math.atan2(ry, rx) - heading) / step
            extent = math.asin(r / math.sqrt(d2)) / step
            for kk in range(math.ceil(bearing - extent) - 1, math.floor(bearing + extent) + 2):
                k = kk % n
                dx, dy = dirs[k]
                b = dx * rx + dy * ry
                disc = b * b - c
                if disc >= 0.0 and b > 0.0:
                    t = b - math.sqrt(disc)
                    if t < out[k]:
                        out[k] = t
        return out
