import numpy as np
import pytest
import torch

from semmap_vo import config as C
from semmap_vo import data as D
from semmap_vo import geometry as G
from semmap_vo import losses as L
from semmap_vo.model import VONet
from semmap_vo.synthpair import make_pair


def fake_seq(n=40, seed=0):
    rng = np.random.default_rng(seed)
    import cv2
    rgb = np.stack([cv2.GaussianBlur(rng.integers(0, 255, (C.HEIGHT, C.WIDTH, 3), dtype=np.uint8), (3, 3), 0)
                    for _ in range(n)])
    depth = np.full((n, C.HEIGHT, C.WIDTH), 2.0, np.float16)
    depth[:, :5] = 0
    cover = np.ones((C.HEIGHT, C.WIDTH), bool)
    return D.Sequence("fake", rgb, depth, cover, np.arange(n) / 30.0)


def test_sampler_chunks_continue_and_reset():
    seq = fake_seq()
    s = D.ChunkSampler([seq], batch=3, length=4, max_chunks=3, strides=(1,), augment=False, seed=0)
    prev = s.next()
    assert prev["reset"].all()
    assert prev["image"].shape == (3, 5, 3, C.HEIGHT, C.WIDTH) and prev["depth"].shape == (3, 5, 1, C.HEIGHT, C.WIDTH)
    for _ in range(6):
        b = s.next()
        for k in range(3):
            if not b["reset"][k]:  # a continued stream starts with the previous chunk's last frame
                assert np.array_equal(b["rgb"][k, 0], prev["rgb"][k, -1])
        prev = b


def test_sampler_augmentation_keeps_depth_aligned():
    seq = fake_seq()
    seq.depth[:, :, :10] = 0  # left band invalid
    s = D.ChunkSampler([seq], batch=16, length=2, strides=(1, 2), augment=True, seed=1)
    b = s.next()
    for k in range(16):
        left = (b["depth"][k, :, 0, :, :10] == 0).all()
        right = (b["depth"][k, :, 0, :, -10:] == 0).all()
        assert left != right  # flipped streams have the band on the right
    assert b["rgb"].min() >= 0 and b["rgb"].max() <= 1


def test_sampler_is_deterministic():
    seq = fake_seq()
    a = D.ChunkSampler([seq], batch=2, length=3, seed=7).next()
    b = D.ChunkSampler([seq], batch=2, length=3, seed=7).next()
    assert np.array_equal(a["rgb"], b["rgb"])


def test_depth_losses():
    gt = torch.full((2, 1, C.HEIGHT, C.WIDTH), 2.0)
    gt[:, :, :4] = 0
    cov = torch.ones(2, 1, C.HEIGHT, C.WIDTH)
    assert float(L.depth_supervised_loss(gt.clamp_min(0.5), gt, cov)) < 1e-3
    assert float(L.depth_supervised_loss(gt.clamp_min(0.5) * 1.2, gt, cov)) == pytest.approx(np.log(1.2), rel=1e-2)
    img = torch.rand(2, 3, C.HEIGHT, C.WIDTH)
    assert float(L.depth_smoothness_loss(torch.full_like(gt, 3.0), img)) == pytest.approx(0.0, abs=1e-6)


def test_chunk_losses_run_and_backpropagate_to_every_part():
    p = make_pair()
    net = VONet()
    rgb = torch.from_numpy(np.stack([p["rgb_a"], p["rgb_b"], p["rgb_a"]])).permute(0, 3, 1, 2)[None]
    dep = torch.from_numpy(np.stack([p["depth_a"], p["depth_b"], p["depth_a"]]))[None, :, None]
    img = (rgb - torch.tensor(C.MEAN).view(1, 1, 3, 1, 1)) / torch.tensor(C.STD).view(1, 1, 3, 1, 1)
    feats = net.encode(img[0])
    depth = net.depth(*feats)[None]
    h = c = torch.zeros(1, C.HIDDEN)
    poses = []
    net.eval()  # BatchNorm with one pair
    for t in range(2):
        pp, h, c = net.pose(*[f[t:t + 1] for f in feats[:3]], *[f[t + 1:t + 2] for f in feats[:3]], h, c)
        poses.append(pp)
    pose = torch.stack(poses, 1)
    K = torch.tensor(C.canonical_K())[None]
    total, terms = L.chunk_losses(rgb, dep, torch.ones(1, 1, 1, C.HEIGHT, C.WIDTH), pose, depth, K)
    assert set(terms) == {"photo", "geo", "temporal", "smooth_v", "depth", "depth_smooth"}
    assert all(np.isfinite(v) for v in terms.values())
    total.backward()
    for name, mod in (("encoder", net.encoder), ("depth", net.depth), ("pose", net.pose)):
        g = sum(float(q.grad.abs().sum()) for q in mod.parameters() if q.grad is not None)
        assert g > 0, name


def test_temporal_loss_prefers_consistent_composition():
    """Frames a, b, a: with the true motions (there and back) the 2-step composition is identity."""
    p = make_pair()
    I = torch.from_numpy(np.stack([p["rgb_a"], p["rgb_b"], p["rgb_a"]])).permute(0, 3, 1, 2)[None]
    Dd = torch.from_numpy(np.stack([p["depth_a"], p["depth_b"], p["depth_a"]]))[None, :, None]
    K = torch.tensor(C.canonical_K())[None]
    cov = torch.ones(1, 1, C.HEIGHT, C.WIDTH)
    T = torch.tensor(p["T_a_b"], dtype=torch.float32)
    good = torch.stack([T, G.inverse(T[None])[0]])[None]
    bad = torch.stack([T, T])[None]
    assert float(L.temporal_loss(I, Dd, good, K, cov, 1.0)) < 0.2 * float(L.temporal_loss(I, Dd, bad, K, cov, 1.0))


def test_teacher_mirror_and_inverse_match_the_geometry():
    """Mirroring the images maps T to S T S (S = diag(-1, 1, 1)); reversal maps it to T^-1."""
    rng = np.random.default_rng(3)
    p = np.concatenate([rng.normal(0, 0.05, (5, 3)), rng.normal(0, 0.1, (5, 3))], 1).astype(np.float64)
    T = G.pose6_to_mat(torch.from_numpy(p)).numpy()
    S = np.diag([-1.0, 1, 1, 1])
    Tm = G.pose6_to_mat(torch.from_numpy(D.mirror_pose6(p))).numpy()
    assert np.allclose(Tm, S @ T @ S, atol=1e-9)
    Ti = G.pose6_to_mat(torch.from_numpy(D.invert_pose6(p))).numpy()
    assert np.allclose(Ti, np.linalg.inv(T), atol=1e-9)


def test_sampler_teacher_follows_reversal_and_flip():
    seq = fake_seq(30)
    n = len(seq)
    p = np.zeros((n, 6), np.float32)
    p[:, 0] = np.arange(n) * 1e-3 + 0.01  # a recognisable motion per frame
    p[:, 4] = 0.02
    seq.teacher = {1: (p, np.ones(n, bool))}
    s = D.ChunkSampler([seq], batch=32, length=3, strides=(1,), augment=True, seed=2)
    b = s.next()
    for k, st in enumerate(s.streams):
        assert b["teacher_ok"][k].all()
        tx = b["teacher"][k, :, 0]
        sign = -1 if st.flip else 1
        if st.direction > 0:
            assert np.all(np.sign(tx) == sign) and np.allclose(b["teacher"][k, :, 4], 0.02 * sign)
        else:
            assert np.all(np.sign(tx) == -sign) and np.allclose(b["teacher"][k, :, 4], -0.02 * sign)


def test_teacher_loss_zero_at_teacher_and_skips_failures():
    t = torch.randn(2, 3, 6) * 0.01
    ok = torch.tensor([[1.0, 1, 0], [1, 1, 1]])
    assert float(L.teacher_pose_loss(t, t, ok)) == pytest.approx(6 * 0.1, rel=1e-4)  # sqrt(1e-2) per dof
    bad = t.clone()
    bad[0, 2] += 1.0  # only a skipped pair is wrong
    assert float(L.teacher_pose_loss(bad, t, ok)) == pytest.approx(6 * 0.1, rel=1e-4)
