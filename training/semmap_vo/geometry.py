"""Rigid-motion and camera geometry (torch, batched), used by the losses and the evaluator.

Conventions
- A pose6 is [tx, ty, tz, rx, ry, rz]: T = [R | t] with R = exp([r]x) (axis-angle, radians) and t
  in metres. The network predicts T_prev_cur (X_prev = R X_cur + t).
- se3_exp / se3_log are the proper exponential coordinates (twist [v, w]); they are here for
  completeness and tests; the network's pose6 is NOT a twist (its t is the translation itself).
- Pixel coordinates: u right, v down, pixel centres at integers; camera x right, y down, z forward.
"""
import torch
import torch.nn.functional as F

_EPS = 1e-6


def hat(w):
    """(..., 3) -> (..., 3, 3) skew-symmetric matrices."""
    z = torch.zeros_like(w[..., 0])
    return torch.stack([
        torch.stack([z, -w[..., 2], w[..., 1]], -1),
        torch.stack([w[..., 2], z, -w[..., 0]], -1),
        torch.stack([-w[..., 1], w[..., 0], z], -1)], -2)


def _sin_coeffs(theta2):
    """A = sin(t)/t, B = (1-cos t)/t^2, Cc = (t - sin t)/t^3, stable at small angles."""
    theta = torch.sqrt(theta2.clamp_min(1e-12))
    small = theta2 < 1e-6
    A = torch.where(small, 1 - theta2 / 6, torch.sin(theta) / theta)
    B = torch.where(small, 0.5 - theta2 / 24, (1 - torch.cos(theta)) / theta2.clamp_min(1e-12))
    Cc = torch.where(small, 1.0 / 6 - theta2 / 120, (theta - torch.sin(theta)) / (theta2 * theta).clamp_min(1e-12))
    return A, B, Cc


def so3_exp(w):
    """Axis-angle (..., 3) -> rotation (..., 3, 3) (Rodrigues)."""
    theta2 = (w * w).sum(-1)[..., None, None]
    A, B, _ = _sin_coeffs(theta2)
    K = hat(w)
    eye = torch.eye(3, dtype=w.dtype, device=w.device).expand(K.shape)
    return eye + A * K + B * (K @ K)


def so3_log(R):
    """Rotation (..., 3, 3) -> axis-angle (..., 3); accurate away from pi (VO steps are small)."""
    tr = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2]
    cos = ((tr - 1) / 2).clamp(-1 + 1e-7, 1 - 1e-7)
    theta = torch.acos(cos)
    v = torch.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    s = torch.sin(theta)
    scale = torch.where(theta < 1e-4, 0.5 + theta * theta / 12, theta / (2 * s.clamp_min(1e-12)))
    return v * scale[..., None]


def pose6_to_mat(p):
    """(..., 6) [t, r] -> (..., 4, 4)."""
    R = so3_exp(p[..., 3:6])
    T = torch.zeros(p.shape[:-1] + (4, 4), dtype=p.dtype, device=p.device)
    T[..., :3, :3] = R
    T[..., :3, 3] = p[..., 0:3]
    T[..., 3, 3] = 1
    return T


def mat_to_pose6(T):
    return torch.cat([T[..., :3, 3], so3_log(T[..., :3, :3])], -1)


def se3_exp(xi):
    """Twist (..., 6) [v, w] -> (..., 4, 4)."""
    v, w = xi[..., :3], xi[..., 3:]
    theta2 = (w * w).sum(-1)[..., None, None]
    A, B, Cc = _sin_coeffs(theta2)
    K = hat(w)
    eye = torch.eye(3, dtype=xi.dtype, device=xi.device).expand(K.shape)
    R = eye + A * K + B * (K @ K)
    V = eye + B * K + Cc * (K @ K)
    T = torch.zeros(xi.shape[:-1] + (4, 4), dtype=xi.dtype, device=xi.device)
    T[..., :3, :3] = R
    T[..., :3, 3] = (V @ v[..., None])[..., 0]
    T[..., 3, 3] = 1
    return T


def se3_log(T):
    """(..., 4, 4) -> twist (..., 6) [v, w]."""
    w = so3_log(T[..., :3, :3])
    theta2 = (w * w).sum(-1)[..., None, None]
    A, B, _ = _sin_coeffs(theta2)
    K = hat(w)
    eye = torch.eye(3, dtype=T.dtype, device=T.device).expand(K.shape)
    # V^-1 = I - K/2 + (1/theta^2)(1 - A/(2B)) K^2
    small = theta2 < 1e-6
    coef = torch.where(small, torch.full_like(theta2, 1.0 / 12), (1 - A / (2 * B)) / theta2.clamp_min(1e-12))
    Vinv = eye - 0.5 * K + coef * (K @ K)
    v = (Vinv @ T[..., :3, 3:4])[..., 0]
    return torch.cat([v, w], -1)


def inverse(T):
    R = T[..., :3, :3]
    t = T[..., :3, 3:4]
    Ti = torch.zeros_like(T)
    Ti[..., :3, :3] = R.transpose(-1, -2)
    Ti[..., :3, 3:4] = -R.transpose(-1, -2) @ t
    Ti[..., 3, 3] = 1
    return Ti


def pixel_grid(h, w, dtype=torch.float32, device="cpu"):
    """(3, h*w) homogeneous pixel coordinates (u, v, 1), row-major."""
    v, u = torch.meshgrid(torch.arange(h, dtype=dtype, device=device),
                          torch.arange(w, dtype=dtype, device=device), indexing="ij")
    return torch.stack([u.reshape(-1), v.reshape(-1), torch.ones(h * w, dtype=dtype, device=device)], 0)


def backproject(depth, K):
    """depth (N,1,H,W), K (N,3,3) -> points (N,3,H*W) in the camera frame."""
    n, _, h, w = depth.shape
    pix = pixel_grid(h, w, depth.dtype, depth.device)
    rays = torch.linalg.inv(K) @ pix.unsqueeze(0)
    return rays * depth.reshape(n, 1, -1)


def transform(T, X):
    """T (N,4,4), X (N,3,M) -> (N,3,M)."""
    return T[:, :3, :3] @ X + T[:, :3, 3:4]


def project(X, K):
    """X (N,3,M) -> uv (N,2,M), z (N,1,M)."""
    z = X[:, 2:3]
    p = K @ (X / z.clamp_min(_EPS))
    return p[:, :2], z


def sample(img, uv, h, w, mode="bilinear"):
    """Sample img (N,C,H,W) at pixel coords uv (N,2,h*w) -> (N,C,h,w) (zeros outside)."""
    n = img.shape[0]
    H, W = img.shape[-2:]
    gx = 2 * uv[:, 0] / (W - 1) - 1
    gy = 2 * uv[:, 1] / (H - 1) - 1
    grid = torch.stack([gx, gy], -1).reshape(n, h, w, 2)
    return F.grid_sample(img, grid, mode=mode, padding_mode="zeros", align_corners=True)


def in_view(uv, z, h, w, margin=0.5):
    """Mask (N,1,M): projection lands inside the image and in front of the camera."""
    u, v = uv[:, 0:1], uv[:, 1:2]
    return ((u >= -margin) & (u <= w - 1 + margin) & (v >= -margin) & (v <= h - 1 + margin) & (z > 0.05)).float()


def warp(src, depth_tgt, T_src_tgt, K):
    """Warp src (N,C,H,W) into the target view through the target's depth.

    Each target pixel p with depth d goes to X = d K^-1 p, X' = T_src_tgt X, p' = proj(X');
    returns (warped src (N,C,H,W), valid (N,1,H,W), projected uv (N,2,HW), z' (N,1,HW)).
    valid = target depth valid (> 0) and p' inside src and in front of the camera.
    """
    n, _, h, w = depth_tgt.shape
    X = backproject(depth_tgt, K)
    Xs = transform(T_src_tgt, X)
    uv, z = project(Xs, K)
    warped = sample(src, uv, h, w)
    valid = in_view(uv, z, h, w) * (depth_tgt.reshape(n, 1, -1) > 0).float()
    return warped, valid.reshape(n, 1, h, w), uv, z
