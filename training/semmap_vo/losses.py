"""Self-supervised VO losses. None of them uses a pose: the only supervision is the images and
the sensor depth (training only), which fixes the metric scale.

Notation: frames a and b of one sequence, T_a_b the predicted motion (X_a = T_a_b X_b), D the
sensor depth (metres, 0 = invalid), `cover` the canonical pixels that lie inside the source image.
Each term is one function; `chunk_losses` combines them over a recurrent chunk.
"""
import torch
import torch.nn.functional as F

from . import geometry as G


def ssim(x, y):
    """Per-pixel (1 - SSIM)/2 over 3x3 windows, (N,C,H,W) -> (N,1,H,W) (channel mean)."""
    c1, c2 = 0.01 ** 2, 0.03 ** 2
    x = F.pad(x, (1, 1, 1, 1), mode="reflect")
    y = F.pad(y, (1, 1, 1, 1), mode="reflect")
    mx, my = F.avg_pool2d(x, 3, 1), F.avg_pool2d(y, 3, 1)
    sx = F.avg_pool2d(x * x, 3, 1) - mx * mx
    sy = F.avg_pool2d(y * y, 3, 1) - my * my
    sxy = F.avg_pool2d(x * y, 3, 1) - mx * my
    s = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sx + sy + c2))
    return ((1 - s) / 2).clamp(0, 1).mean(1, keepdim=True)


def _masked_mean(x, m):
    return (x * m).sum() / m.sum().clamp_min(1.0)


class Warp:
    """Frame b warped into frame a through a's sensor depth and T_b_a (shared by the photometric and
    geometric terms: one grid_sample per direction).

    img    b's image at a's pixels' projections (N,C,H,W)
    depth  b's sensor depth there (bilinear; 0 where any of its 4 taps is invalid or uncovered)
    z      depth of a's points in b's frame (N,1,H,W)
    known  b's depth is known at the projection (N,1,H,W)
    mask   a's depth valid, inside a's and b's source images, in front of b, and not occluded in b
           (z <= depth (1 + occl_tol) where depth is known)
    """

    def __init__(self, img_b, D_a, D_b, T_b_a, K, cover_a, cover_b, occl_tol=0.05):
        n, c, h, w = img_b.shape
        X = G.transform(T_b_a, G.backproject(D_a, K))
        uv, z = G.project(X, K)
        vb = (D_b > 0).float() * cover_b
        stack = torch.cat([img_b, D_b * vb, vb, cover_b.expand(n, 1, h, w)], 1)
        s = G.sample(stack, uv, h, w)
        self.img = s[:, :c]
        self.known = (s[:, c + 1:c + 2] > 0.999).float()
        self.depth = s[:, c:c + 1] / s[:, c + 1:c + 2].clamp_min(1e-6) * self.known
        self.z = z.reshape(n, 1, h, w)
        inside = G.in_view(uv, z, h, w).reshape(n, 1, h, w) * (s[:, c + 2:c + 3] > 0.999).float()
        mask = inside * cover_a * (D_a > 0).float()
        visible = torch.where(self.known > 0, (self.z <= self.depth * (1 + occl_tol)).float(),
                              torch.ones_like(self.z))
        self.mask = (mask * visible).detach()
        self.inside = (mask * self.known).detach()


def photometric_loss(I_a, warp, alpha=0.85):
    """Reprojection error of frame b warped into a (alpha*SSIM + (1-alpha)*L1), masked mean
    (mask: valid depth, inside both images, not occluded; see Warp)."""
    err = alpha * ssim(warp.img, I_a) + (1 - alpha) * (warp.img - I_a).abs().mean(1, keepdim=True)
    return _masked_mean(err, warp.mask)


def geometric_loss(warp, sigma=0.05):
    """3D alignment of the two sensor depth clouds: a's points moved into b and projected must
    land on b's depth there. Relative residual r = (z' - D_b(p')) / z', Geman-McClure
    rho = r^2 / (r^2 + sigma^2) (robust to occlusions and depth noise), masked mean."""
    r = (warp.z - warp.depth) / warp.z.clamp_min(1e-3)
    rho = r * r / (r * r + sigma * sigma)
    return _masked_mean(rho, warp.inside)


def pair_loss(I_a, I_b, D_a, D_b, T_a_b, K, cov_a, cov_b, w_geo):
    """Photometric + geometric terms for one frame pair, in both directions."""
    T_b_a = G.inverse(T_a_b)
    w_ab = Warp(I_b, D_a, D_b, T_b_a, K, cov_a, cov_b)  # b seen from a
    w_ba = Warp(I_a, D_b, D_a, T_a_b, K, cov_b, cov_a)  # a seen from b
    ph = photometric_loss(I_a, w_ab) + photometric_loss(I_b, w_ba)
    geo = geometric_loss(w_ab) + geometric_loss(w_ba)
    return 0.5 * ph, 0.5 * geo * w_geo


def temporal_loss(I, D, T_rel, K, cover, w_geo, span=2):
    """Consistency over the sequence the LSTM sees: the composed predictions
    T_t_{t+span} = T_t_{t+1} ... T_{t+span-1}_{t+span} must explain frames t and t+span
    (photometric + geometric, as pair_loss); I (B,L+1,3,H,W), T_rel (B,L,4,4)."""
    L = T_rel.shape[1]
    terms = []
    for t in range(L - span + 1):
        T = T_rel[:, t]
        for k in range(1, span):
            T = T @ T_rel[:, t + k]
        ph, geo = pair_loss(I[:, t], I[:, t + span], D[:, t], D[:, t + span], T, K, cover, cover, w_geo)
        terms.append(ph + geo)
    return torch.stack(terms).mean() if terms else I.new_zeros(())


def velocity_smoothness_loss(pose6):
    """Small penalty on the change of the predicted per-frame motion (B,L,6) (Charbonnier)."""
    if pose6.shape[1] < 2:
        return pose6.new_zeros(())
    d = pose6[:, 1:] - pose6[:, :-1]
    scale = pose6.new_tensor([1.0, 1.0, 1.0, 1.0, 1.0, 1.0]) / 0.01
    return torch.sqrt((d * scale) ** 2 + 1e-4).mean()


def depth_supervised_loss(pred, gt, cover):
    """L1 of log depth against the sensor (relative error: metric scale is what we want) plus a
    scale-invariant term (spread of the log error) for the structure; valid pixels only."""
    m = ((gt > 0) & (cover > 0)).float()
    e = (torch.log(pred.clamp_min(1e-3)) - torch.log(gt.clamp_min(1e-3))) * m
    n = m.sum(dim=(1, 2, 3)).clamp_min(1.0)
    l1 = e.abs().sum(dim=(1, 2, 3)) / n
    mu = e.sum(dim=(1, 2, 3)) / n
    si = torch.sqrt(((e * e).sum(dim=(1, 2, 3)) / n - mu * mu).clamp_min(1e-8))
    return (l1 + 0.5 * si).mean()


def depth_smoothness_loss(pred, img):
    """Edge-aware smoothness of the mean-normalised inverse depth (weaker across image edges)."""
    disp = 1.0 / pred.clamp_min(1e-3)
    disp = disp / disp.mean(dim=(2, 3), keepdim=True)
    dx = (disp[..., :, 1:] - disp[..., :, :-1]).abs()
    dy = (disp[..., 1:, :] - disp[..., :-1, :]).abs()
    ix = (img[..., :, 1:] - img[..., :, :-1]).abs().mean(1, keepdim=True)
    iy = (img[..., 1:, :] - img[..., :-1, :]).abs().mean(1, keepdim=True)
    return (dx * torch.exp(-ix)).mean() + (dy * torch.exp(-iy)).mean()


def teacher_pose_loss(pose6, teacher, ok, scale=0.01):
    """Warm-up term: Charbonnier distance of the predicted motion to the RGB-D odometry teacher's
    (data.teacher_motions: OpenCV RGB-D ICP on the same training frames' images and sensor depth,
    not ground truth), 1 cm ~ 0.01 rad ~ 1; pairs where the teacher failed are skipped. It gives the
    pose branch a dense, well-conditioned signal in the first thousands of steps, where the
    photometric terms alone leave it near zero motion; the trainer decays its weight."""
    d = (pose6 - teacher) / scale
    rho = torch.sqrt(d * d + 1e-2).sum(-1)
    return (rho * ok).sum() / ok.sum().clamp_min(1.0)


DEFAULT_WEIGHTS = {"photo": 1.0, "geo": 0.5, "temporal": 0.5, "smooth_v": 0.002, "depth": 0.5, "depth_smooth": 0.01, "teacher": 0.1}


def chunk_losses(rgb, depth_gt, cover, pose6, depth_pred, K, weights=None, teacher=None, teacher_ok=None):
    """All terms over one chunk. rgb (B,L+1,3,H,W) in [0,1], depth_gt (B,L+1,1,H,W),
    cover (B,1,1,H,W), pose6 (B,L,6) predicted T_t_{t+1}, depth_pred (B,L+1,1,H,W), K (B,3,3).
    teacher (B,L,6), teacher_ok (B,L): optional RGB-D odometry motions (teacher_pose_loss).
    Returns (total, dict of weighted terms as floats)."""
    w = dict(DEFAULT_WEIGHTS, **(weights or {}))
    B, L1 = rgb.shape[:2]
    L = L1 - 1
    cov = cover[:, 0]
    T_rel = G.pose6_to_mat(pose6)  # (B,L,4,4)
    # pairs (t, t+1), batched over t
    Ia = rgb[:, :-1].reshape(B * L, *rgb.shape[2:])
    Ib = rgb[:, 1:].reshape(B * L, *rgb.shape[2:])
    Da = depth_gt[:, :-1].reshape(B * L, *depth_gt.shape[2:])
    Db = depth_gt[:, 1:].reshape(B * L, *depth_gt.shape[2:])
    KL = K.repeat_interleave(L, 0)
    covL = cov.repeat_interleave(L, 0)
    ph, geo = pair_loss(Ia, Ib, Da, Db, T_rel.reshape(B * L, 4, 4), KL, covL, covL, 1.0)
    terms = {"photo": ph * w["photo"], "geo": geo * w["geo"]}
    if L >= 2 and w["temporal"] > 0:
        terms["temporal"] = temporal_loss(rgb, depth_gt, T_rel, K, cov, w["geo"] / max(w["photo"], 1e-9)) * w["temporal"]
    terms["smooth_v"] = velocity_smoothness_loss(pose6) * w["smooth_v"]
    dp = depth_pred.reshape(B * L1, *depth_pred.shape[2:])
    dg = depth_gt.reshape(B * L1, *depth_gt.shape[2:])
    covD = cov.repeat_interleave(L1, 0)
    terms["depth"] = depth_supervised_loss(dp, dg, covD) * w["depth"]
    terms["depth_smooth"] = depth_smoothness_loss(dp, rgb.reshape(B * L1, *rgb.shape[2:])) * w["depth_smooth"]
    if teacher is not None and w["teacher"] > 0:
        terms["teacher"] = teacher_pose_loss(pose6, teacher, teacher_ok) * w["teacher"]
    total = sum(terms.values())
    return total, {k: float(v.detach()) for k, v in terms.items()}
