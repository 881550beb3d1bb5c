"""A pure-numpy synthetic RGB-D pair: a textured slanted plane seen by the canonical camera from two
known poses. Tests use it to check the geometry and the losses without semmap-synth."""
import numpy as np

from . import config as C


def _texture(X, Y):
    """Smooth colour texture on the plane (values in [0, 1]), (..., 3)."""
    r = 0.5 + 0.25 * np.sin(7 * X) * np.cos(5 * Y) + 0.2 * np.sin(13 * X + 3 * Y)
    g = 0.5 + 0.3 * np.cos(6 * Y + 2 * X) + 0.15 * np.sin(17 * Y)
    b = 0.5 + 0.25 * np.sin(9 * X - 4 * Y) + 0.2 * np.cos(11 * X)
    return np.clip(np.stack([r, g, b], -1), 0, 1)


def render(T_world_cam, plane_n=(0.0, -0.3, -1.0), plane_d=2.5):
    """Render the plane n.X + d = 0 (world) from camera pose T_world_cam.
    Returns rgb (H, W, 3) float32 in [0, 1] and depth (H, W) float32 metres."""
    n = np.asarray(plane_n, np.float64)
    n = n / np.linalg.norm(n)
    Kinv = np.linalg.inv(np.array(C.canonical_K()))
    v, u = np.mgrid[0:C.HEIGHT, 0:C.WIDTH].astype(np.float64)
    rays_c = np.stack([u, v, np.ones_like(u)], -1) @ Kinv.T  # z = 1
    R, t = T_world_cam[:3, :3], T_world_cam[:3, 3]
    rays_w = rays_c @ R.T
    s = -(n @ t + plane_d) / (rays_w @ n)  # ray parameter = camera z (rays have z = 1)
    X = t + rays_w * s[..., None]
    # a local 2D frame on the plane for the texture
    a = np.cross(n, [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(n, a)
    rgb = _texture(X @ a, X @ b).astype(np.float32)
    depth = np.where(s > 0, s, 0).astype(np.float32)
    return rgb, depth


def _rodrigues(r):
    r = np.asarray(r, np.float64)
    th = np.linalg.norm(r)
    if th < 1e-12:
        return np.eye(3)
    k = r / th
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * Kx + (1 - np.cos(th)) * Kx @ Kx


def make_pair(motion=(0.03, -0.01, 0.02, 0.01, -0.02, 0.015)):
    """Frames a (at the world origin) and b (at T_a_b = pose6 `motion`): dict(rgb_a, rgb_b, depth_a,
    depth_b, T_a_b (4x4))."""
    T = np.eye(4)
    T[:3, :3] = _rodrigues(motion[3:6])
    T[:3, 3] = motion[:3]
    ra, da = render(np.eye(4))
    rb, db = render(T)
    return {"rgb_a": ra, "rgb_b": rb, "depth_a": da, "depth_b": db, "T_a_b": T}
