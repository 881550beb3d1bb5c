import os

import numpy as np
import pytest
import torch

from semmap_vo import evaluate as E


def random_traj(n=60, seed=0):
    rng = np.random.default_rng(seed)
    P = []
    T = np.eye(4)
    for _ in range(n):
        d = np.eye(4)
        d[:3, :3] = E.pose6_to_T(np.r_[0, 0, 0, rng.normal(0, 0.03, 3)])[:3, :3]
        d[:3, 3] = rng.normal(0, 0.02, 3) + [0.01, 0, 0]
        T = T @ d
        P.append(T.copy())
    return np.arange(n) / 30.0, np.array(P)


def test_quaternion_round_trip():
    _, P = random_traj()
    for T in P:
        assert np.allclose(E.quat_to_rot(E.rot_to_quat(T[:3, :3])), T[:3, :3], atol=1e-9)


def test_tum_write_read(tmp_path):
    s, P = random_traj()
    E.write_tum_trajectory(tmp_path / "t.txt", s, P)
    s2, P2 = E.read_tum_trajectory(tmp_path / "t.txt")
    assert np.allclose(s, s2) and np.allclose(P, P2, atol=1e-5)


def test_ate_rigid_vs_sim3():
    s, P = random_traj()
    # estimate = ground truth moved rigidly and scaled by 0.5
    A = E.pose6_to_T([1, 2, 3, 0.3, -0.2, 0.1])
    est = np.array([A @ T for T in P])
    est[:, :3, 3] *= 0.5
    r = E.ate(s, est, s, P)
    assert r["ate_sim3_rmse_m"] < 1e-9
    assert r["sim3_scale"] == pytest.approx(2.0, rel=1e-9)
    assert r["ate_rigid_rmse_m"] > 0.01  # scale error counts without Sim(3)
    r2 = E.ate(s, np.array([A @ T for T in P]), s, P)
    assert r2["ate_rigid_rmse_m"] < 1e-9


def test_rpe_zero_for_rigidly_moved_trajectory():
    s, P = random_traj()
    A = E.pose6_to_T([1, 2, 3, 0.3, -0.2, 0.1])
    r = E.rpe(s, np.array([A @ T for T in P]), s, P)
    assert r["rpe_trans_rmse_m"] < 1e-9 and r["rpe_rot_mean_deg"] < 1e-5


def test_onnx_and_torch_runners_agree_on_a_folder(tmp_path):
    """Run a random-weight model over a tiny folder with both back ends (no ground truth needed)."""
    from test_guard import make_folder
    from semmap_vo.export import export_onnx
    from semmap_vo.model import VONet
    torch.manual_seed(0)
    net = VONet()
    ck = tmp_path / "m.pt"
    torch.save({"model": net.state_dict()}, ck)
    onnx = str(tmp_path / "m.onnx")
    export_onnx(net, onnx)
    f = make_folder(tmp_path, n=6)
    s1, P1, _ = E.run_sequence(E.load_runner(str(ck)), str(f))
    s2, P2, _ = E.run_sequence(E.load_runner(onnx), str(f))
    assert len(P1) == 6 and np.allclose(P1[0], np.eye(4))
    assert np.abs(P1 - P2).max() < 1e-4
