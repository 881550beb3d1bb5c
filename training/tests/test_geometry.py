import numpy as np
import pytest
import torch

from semmap_vo import config as C
from semmap_vo import geometry as G
from semmap_vo import losses as L
from semmap_vo.synthpair import make_pair


def rand_pose6(n, seed, trans=0.5, rot=1.0):
    g = torch.Generator().manual_seed(seed)
    t = (torch.rand(n, 3, generator=g, dtype=torch.float64) - 0.5) * 2 * trans
    r = (torch.rand(n, 3, generator=g, dtype=torch.float64) - 0.5) * 2 * rot
    return torch.cat([t, r], 1)


def test_so3_exp_log_round_trip():
    w = rand_pose6(200, 0, rot=1.5)[:, 3:]
    w = torch.cat([w, torch.zeros(1, 3, dtype=torch.float64), torch.tensor([[1e-7, -2e-7, 3e-8]], dtype=torch.float64)])
    R = G.so3_exp(w)
    assert torch.allclose(R @ R.transpose(-1, -2), torch.eye(3, dtype=torch.float64).expand_as(R), atol=1e-10)
    assert torch.allclose(torch.linalg.det(R), torch.ones(len(w), dtype=torch.float64), atol=1e-10)
    assert torch.allclose(G.so3_log(R), w, atol=1e-7)


def test_se3_exp_log_round_trip():
    xi = rand_pose6(200, 1)
    T = G.se3_exp(xi)
    assert torch.allclose(G.se3_log(T), xi, atol=1e-7)
    # small-angle branch
    xi_s = rand_pose6(20, 2, rot=1e-5)
    assert torch.allclose(G.se3_log(G.se3_exp(xi_s)), xi_s, atol=1e-9)


def test_se3_exp_matches_matrix_exponential():
    xi = rand_pose6(5, 3)
    for k in range(5):
        A = torch.zeros(4, 4, dtype=torch.float64)
        A[:3, :3] = G.hat(xi[k, 3:])
        A[:3, 3] = xi[k, :3]
        assert torch.allclose(G.se3_exp(xi[k]), torch.linalg.matrix_exp(A), atol=1e-9)


def test_pose6_round_trip_and_inverse():
    p = rand_pose6(50, 4)
    T = G.pose6_to_mat(p)
    assert torch.allclose(G.mat_to_pose6(T), p, atol=1e-7)
    assert torch.allclose(T @ G.inverse(T), torch.eye(4, dtype=torch.float64).expand_as(T), atol=1e-10)


def test_backproject_project_round_trip():
    K = torch.tensor(C.canonical_K())[None]
    d = torch.rand(1, 1, C.HEIGHT, C.WIDTH) * 3 + 0.5
    X = G.backproject(d, K)
    uv, z = G.project(X, K)
    pix = G.pixel_grid(C.HEIGHT, C.WIDTH)[:2][None]
    assert torch.allclose(uv, pix, atol=1e-3)
    assert torch.allclose(z.reshape_as(d), d, atol=1e-5)


def _pair_tensors(p):
    f = lambda a: torch.from_numpy(a)
    I_a = f(p["rgb_a"]).permute(2, 0, 1)[None]
    I_b = f(p["rgb_b"]).permute(2, 0, 1)[None]
    D_a = f(p["depth_a"])[None, None]
    D_b = f(p["depth_b"])[None, None]
    T_a_b = torch.tensor(p["T_a_b"], dtype=torch.float32)[None]
    return I_a, I_b, D_a, D_b, T_a_b


def test_warp_with_true_motion_gives_near_zero_loss():
    """Pure-numpy textured plane seen from two known poses: the true motion explains the pair."""
    I_a, I_b, D_a, D_b, T_a_b = _pair_tensors(make_pair())
    K = torch.tensor(C.canonical_K())[None]
    cov = torch.ones(1, 1, C.HEIGHT, C.WIDTH)
    T_b_a = G.inverse(T_a_b)
    w_true = L.Warp(I_b, D_a, D_b, T_b_a, K, cov, cov)
    true_ph = float(L.photometric_loss(I_a, w_true))
    true_geo = float(L.geometric_loss(w_true))
    w_id = L.Warp(I_b, D_a, D_b, torch.eye(4)[None], K, cov, cov)
    id_ph = float(L.photometric_loss(I_a, w_id))
    id_geo = float(L.geometric_loss(w_id))
    assert true_ph < 0.01 and true_geo < 1e-3
    assert id_ph > 10 * true_ph and id_geo > 10 * true_geo
    # the warped image matches the target where valid
    warped, valid, _, _ = G.warp(I_b, D_a, T_b_a, K)
    assert valid.mean() > 0.7
    assert float(((warped - I_a).abs() * valid).sum() / valid.sum() / 3) < 0.01


def test_pose_gradient_points_towards_true_motion():
    I_a, I_b, D_a, D_b, T_a_b = _pair_tensors(make_pair())
    K = torch.tensor(C.canonical_K())[None]
    cov = torch.ones(1, 1, C.HEIGHT, C.WIDTH)
    p_true = G.mat_to_pose6(T_a_b)
    p = (p_true * 0.5).clone().requires_grad_(True)
    opt = torch.optim.Adam([p], lr=2e-3)
    for _ in range(150):
        ph, geo = L.pair_loss(I_a, I_b, D_a, D_b, G.pose6_to_mat(p), K, cov, cov, 1.0)
        opt.zero_grad()
        (ph + geo).backward()
        opt.step()
    assert float((p - p_true).abs().max()) < 0.004


def test_synth_sequence_true_motion(synth_seq):
    """semmap-synth pair: warping with the generator's ground-truth motion (read through the
    evaluation module, never the loader) gives a small photometric loss, much below identity."""
    from semmap_vo import data as D
    from semmap_vo.evaluate import read_groundtruth
    s = D.load_sequence(synth_seq)
    gs, gp = read_groundtruth(synth_seq)
    K = torch.tensor(C.canonical_K())[None]
    cov = torch.from_numpy(s.cover.astype(np.float32))[None, None]
    for i in (20, 90):
        j = i + 2
        ga, gb = int(np.argmin(abs(gs - s.stamps[i]))), int(np.argmin(abs(gs - s.stamps[j])))
        T_a_b = torch.tensor(np.linalg.inv(gp[ga]) @ gp[gb], dtype=torch.float32)[None]
        I = torch.from_numpy(s.rgb[[i, j]].astype(np.float32) / 255).permute(0, 3, 1, 2)
        Dd = torch.from_numpy(s.depth[[i, j]].astype(np.float32))[:, None]
        ph_t, geo_t = L.pair_loss(I[:1], I[1:], Dd[:1], Dd[1:], T_a_b, K, cov, cov, 1.0)
        ph_i, geo_i = L.pair_loss(I[:1], I[1:], Dd[:1], Dd[1:], torch.eye(4)[None], K, cov, cov, 1.0)
        assert float(ph_t) < 0.05
        assert float(ph_i) > 3 * float(ph_t)
        assert float(geo_t) < float(geo_i)
