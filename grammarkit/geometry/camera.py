"""Cameras for the CPU renderer: an explicit description (`Camera`) and its resolution for one
model and image size (`View`), which projects world points to pixels.

Conventions (documented in docs/rendering.md):
- World up is +z by default (`up=`); any up vector works, e.g. (0, 1, 0) for y-up glTF files.
- `pitch` is the camera's elevation above the horizon (degrees; 30 looks down at 30 degrees),
  `yaw` its azimuth around the up axis: yaw 0 puts the camera on the -y side looking towards +y
  (the model's front), negative yaw turns it towards +x, so the default yaw -45 views the
  front-right corner. This matches Nishida et al.'s fixed mass/roof camera (pitch 30, yaw -45,
  fov 45) under the usual y-up -> z-up mapping.
- `fov` is the vertical field of view. With `distance=None` the camera backs off until every
  vertex fits inside the image with `margin` to spare, and the model is centred in the image
  (the sketch recognizer relies on this framing being a pure function of the geometry).
- Pixel coordinates: x to the right, y down, pixel (i, j) covers [i, i+1) x [j, j+1).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal, Sequence

import numpy as np

Vec3 = tuple[float, float, float]
Projection = Literal["perspective", "orthographic"]


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    if n == 0.0 or not math.isfinite(n):
        raise ValueError(f"cannot normalise vector {v}")
    return v / n


def _up_basis(up: np.ndarray) -> np.ndarray:
    """Rows (X', Y', Z') of a right-handed frame with Z' = up, chosen so that up=+z gives the
    identity and up=+y gives the glTF mapping (x, -z, y)."""
    z = _unit(up)
    x_ref = np.array([1.0, 0.0, 0.0])
    if abs(float(z @ x_ref)) > 0.99:  # up along x: use y as the reference right axis
        x_ref = np.array([0.0, 1.0, 0.0])
    x = _unit(x_ref - (x_ref @ z) * z)
    y = np.cross(z, x)
    return np.stack([x, y, z])


@dataclass(frozen=True)
class Camera:
    """What to look at and how; every field explicit so renders are reproducible.

    Orbit mode (default): `pitch`, `yaw`, `distance` around `target`.
    Look-at mode: give `eye` (and optionally `target`); pitch/yaw are then ignored.
    `distance=None` / `target=None` / `ortho_height=None` mean "frame the model".
    """

    pitch: float = 30.0
    yaw: float = -45.0
    fov: float = 45.0  # vertical field of view in degrees (perspective only)
    distance: float | None = None
    target: Vec3 | None = None
    eye: Vec3 | None = None
    up: Vec3 = (0.0, 0.0, 1.0)
    projection: Projection = "perspective"
    ortho_height: float | None = None  # world units visible vertically (orthographic only)
    margin: float = 0.05  # fraction of the image kept free around the framed model

    def __post_init__(self) -> None:
        if self.projection not in ("perspective", "orthographic"):
            raise ValueError(f"unknown projection {self.projection!r}; "
                             "expected 'perspective' or 'orthographic'")
        if not 1.0 <= self.fov <= 170.0:
            raise ValueError(f"fov must be between 1 and 170 degrees, got {self.fov}")
        if not 0.0 <= self.margin < 0.5:
            raise ValueError(f"margin must be in [0, 0.5), got {self.margin}")
        # `not x > 0` (rather than `x <= 0`) so that NaN is refused too
        if self.distance is not None and not 0 < self.distance < math.inf:
            raise ValueError(f"distance must be a positive finite number, got {self.distance}")
        if self.ortho_height is not None and not 0 < self.ortho_height < math.inf:
            raise ValueError(f"ortho_height must be a positive finite number, got {self.ortho_height}")
        for name in ("pitch", "yaw"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be a finite number of degrees, got {getattr(self, name)}")
        for name in ("target", "eye", "up"):
            v = getattr(self, name)
            if v is not None and not (len(v) == 3 and all(math.isfinite(c) for c in v)):
                raise ValueError(f"{name} must be three finite numbers, got {v}")

    # -- constructors for the common cases ---------------------------------------------------
    @classmethod
    def nishida(cls) -> "Camera":
        """Nishida et al. 2016's mass/roof camera: pitch 30, yaw -45, fov 45, framed."""
        return cls()

    @classmethod
    def look_at(cls, eye: Sequence[float], target: Sequence[float] | None = None,
                up: Sequence[float] = (0.0, 0.0, 1.0), fov: float = 45.0) -> "Camera":
        return cls(eye=tuple(map(float, eye)),
                   target=None if target is None else tuple(map(float, target)),
                   up=tuple(map(float, up)), fov=fov)

    @classmethod
    def orthographic(cls, pitch: float = 30.0, yaw: float = -45.0,
                     height: float | None = None, **kw) -> "Camera":
        return cls(pitch=pitch, yaw=yaw, projection="orthographic", ortho_height=height, **kw)

    def with_(self, **changes) -> "Camera":
        return replace(self, **changes)

    # -- resolution ---------------------------------------------------------------------------
    def direction(self) -> tuple[np.ndarray, np.ndarray]:
        """(forward, right) unit vectors in world space for the orbit angles."""
        basis = _up_basis(np.asarray(self.up, dtype=float))
        p, y = math.radians(self.pitch), math.radians(self.yaw)
        horiz = np.array([-math.sin(y), -math.cos(y), 0.0])  # from target towards the eye
        to_eye = math.cos(p) * horiz + math.sin(p) * np.array([0.0, 0.0, 1.0])
        right = np.cross(-horiz, [0.0, 0.0, 1.0])  # defined even when looking straight down
        return basis.T @ (-to_eye), basis.T @ right

    def resolve(self, points: np.ndarray, size: tuple[int, int]) -> "View":
        """Fix the camera for a model (its vertices, world coordinates) and an image size."""
        width, height = int(size[0]), int(size[1])
        if width < 1 or height < 1:
            raise ValueError(f"image size must be positive, got {size}")
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        pts = pts[np.isfinite(pts).all(axis=1)]
        if len(pts) == 0:
            pts = np.array([[-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]])
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        scale = max(float(np.linalg.norm(hi - lo)), 1e-9)
        target = np.asarray(self.target, dtype=float) if self.target is not None else (lo + hi) / 2
        aspect = width / height
        up = np.asarray(self.up, dtype=float)

        if self.eye is not None:
            eye = np.asarray(self.eye, dtype=float)
            forward = _unit(target - eye)
            right = np.cross(forward, up)
            if np.linalg.norm(right) < 1e-9:  # looking along up: any horizontal right will do
                right = np.cross(forward, _up_basis(up)[1])
            right = _unit(right)
        else:
            forward, right = self.direction()
            forward, right = _unit(forward), _unit(right)
        cam_up = np.cross(right, forward)
        fit = 1.0 - 2.0 * self.margin

        if self.projection == "orthographic":
            rel = pts - target
            xs, ys, zs = rel @ right, rel @ cam_up, rel @ forward
            cx, cy = (xs.min() + xs.max()) / 2, (ys.min() + ys.max()) / 2
            if self.target is None and self.eye is None:  # centre the model in the image
                target = target + cx * right + cy * cam_up
                xs, ys = xs - cx, ys - cy
            if self.ortho_height is not None:
                half_h = self.ortho_height / 2
            else:
                half_h = max(np.abs(ys).max(), np.abs(xs).max() / aspect, 1e-9 * scale) / fit
            back = float(self.distance) if self.distance is not None else \
                float(max(zs.max() - zs.min(), scale)) * 2.0
            eye = target - forward * back if self.eye is None else np.asarray(self.eye, float)
            return View(eye=eye, forward=forward, right=right, up=cam_up, size=(width, height),
                        perspective=False, half_w=half_h * aspect, half_h=half_h)

        tan_y = math.tan(math.radians(self.fov) / 2)
        tan_x = tan_y * aspect
        if self.eye is not None:
            eye = np.asarray(self.eye, dtype=float)
        elif self.distance is not None:
            eye = target - forward * float(self.distance)
        else:
            # Distance so that every vertex projects inside the shrunk frustum; then shift the
            # target sideways so the projected model is centred (two rounds converge well).
            for _ in range(3):
                rel = pts - target
                xs, ys, zs = rel @ right, rel @ cam_up, rel @ forward
                dist = max(float(np.max(np.abs(xs) / (tan_x * fit) - zs)),
                           float(np.max(np.abs(ys) / (tan_y * fit) - zs)),
                           float(-zs.min()) + 1e-3 * scale)
                if self.target is not None:
                    break
                depth = zs + dist
                nx, ny = xs / (depth * tan_x), ys / (depth * tan_y)
                cx, cy = (nx.min() + nx.max()) / 2, (ny.min() + ny.max()) / 2
                if abs(cx) < 1e-4 and abs(cy) < 1e-4:
                    break
                target = target + (cx * tan_x * dist) * right + (cy * tan_y * dist) * cam_up
            eye = target - forward * dist
        return View(eye=eye, forward=forward, right=right, up=cam_up, size=(width, height),
                    perspective=True, half_w=tan_x, half_h=tan_y)


@dataclass(frozen=True)
class View:
    """A resolved camera: world -> pixel projection for one image size.

    For perspective views `half_w`/`half_h` are tan(fov/2) horizontally/vertically; for
    orthographic views they are half the visible extent in world units.
    """

    eye: np.ndarray
    forward: np.ndarray
    right: np.ndarray
    up: np.ndarray
    size: tuple[int, int]
    perspective: bool
    half_w: float
    half_h: float

    def scaled(self, factor: int) -> "View":
        """The same view for an image `factor` times larger (supersampling)."""
        w, h = self.size
        return replace(self, size=(w * factor, h * factor))

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Distance in front of the camera along its viewing axis."""
        return (np.asarray(points, dtype=float) - self.eye) @ self.forward

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(pixels (N, 2), depth key (N,)). The key grows with distance and, unlike the depth
        itself, is affine in screen space (-1/depth under perspective), so it can be
        interpolated linearly across a projected triangle."""
        rel = np.asarray(points, dtype=float).reshape(-1, 3) - self.eye
        x, y, w = rel @ self.right, rel @ self.up, rel @ self.forward
        width, height = self.size
        if self.perspective:
            with np.errstate(divide="ignore", invalid="ignore"):
                nx, ny = x / (w * self.half_w), y / (w * self.half_h)
                key = -1.0 / w
        else:
            nx, ny, key = x / self.half_w, y / self.half_h, w
        px = np.stack([(nx + 1.0) * 0.5 * width, (1.0 - ny) * 0.5 * height], axis=1)
        return px, key

    def to_pixels(self, points: np.ndarray) -> np.ndarray:
        return self.project(points)[0]

    def view_vectors(self, points: np.ndarray) -> np.ndarray:
        """Unit-less directions from the camera to `points` (for front/back facing tests)."""
        if self.perspective:
            return np.asarray(points, dtype=float) - self.eye
        return np.broadcast_to(self.forward, np.shape(points))
