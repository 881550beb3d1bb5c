"""Evaluation (the ONLY module that reads ground truth; the trainer never imports it).

Runs the VO network (PyTorch checkpoint or exported ONNX through cv2.dnn) over a TUM-layout
folder from its colour images alone, writes the estimated trajectory (TUM format,
T_world_camera, world = first camera), and compares it with groundtruth.txt:

- ATE RMSE with a rigid (SE(3)) alignment only: metric scale errors count;
- ATE RMSE with a Sim(3) alignment, and the Sim(3) scale factor (estimate -> ground truth);
- RPE over 1 s windows: translation RMSE (m) and rotation mean (deg).

usage: python3 -m semmap_vo.evaluate FOLDER[:START[:END]] --model CKPT.pt|MODEL.onnx [--out traj.txt]
"""
import argparse
import json
import os
import sys
import time

import cv2
import numpy as np

from . import config as C
from .data import (associate, canonical_coverage, nearest_pairs, normalise, parse_camera_yaml, parse_list,
                   parse_spec, to_canonical_rgb)

# ---------------------------------------------------------------------------------------------
# rotations (numpy)


def quat_to_rot(q):
    """[qx, qy, qz, qw] -> 3x3."""
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def rot_to_quat(R):
    """3x3 -> [qx, qy, qz, qw] (qw >= 0)."""
    m = R
    tr = np.trace(m)
    if tr > 0:
        s = np.sqrt(tr + 1.0) * 2
        q = [(m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        q = [0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s]
    elif m[1, 1] > m[2, 2]:
        s = np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        q = [(m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s]
    else:
        s = np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
        q = [(m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s]
    q = np.array(q)
    q /= np.linalg.norm(q)
    return q if q[3] >= 0 else -q


def pose6_to_T(p):
    """Network pose6 [t, axis-angle] -> 4x4 (numpy)."""
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(np.asarray(p[3:6], np.float64).reshape(3, 1))[0]
    T[:3, 3] = p[:3]
    return T


# ---------------------------------------------------------------------------------------------
# trajectories


def read_tum_trajectory(path):
    """TUM file -> (stamps (N,), poses (N,4,4)) T_world_camera."""
    stamps, poses = [], []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            v = [float(x) for x in line.split()[:8]]
            T = np.eye(4)
            T[:3, :3] = quat_to_rot(np.array(v[4:8]))
            T[:3, 3] = v[1:4]
            stamps.append(v[0])
            poses.append(T)
    return np.array(stamps), np.array(poses)


def read_groundtruth(folder):
    return read_tum_trajectory(os.path.join(folder, "groundtruth.txt"))


def write_tum_trajectory(path, stamps, poses):
    with open(path, "w") as f:
        f.write("# timestamp tx ty tz qx qy qz qw (T_world_camera, semmap_vo)\n")
        for t, T in zip(stamps, poses):
            q = rot_to_quat(T[:3, :3])
            f.write(f"{t:.6f} {T[0, 3]:.6f} {T[1, 3]:.6f} {T[2, 3]:.6f} {q[0]:.6f} {q[1]:.6f} {q[2]:.6f} {q[3]:.6f}\n")


def umeyama(src, dst, with_scale):
    """Least-squares s, R, t with dst ~ s R src + t; src, dst (N,3)."""
    mu_s, mu_d = src.mean(0), dst.mean(0)
    xs, xd = src - mu_s, dst - mu_d
    cov = xd.T @ xs / len(src)
    U, D, Vt = np.linalg.svd(cov)
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        S[2, 2] = -1
    R = U @ S @ Vt
    s = (np.trace(np.diag(D) @ S) / (xs ** 2).sum(1).mean()) if with_scale else 1.0
    t = mu_d - s * R @ mu_s
    return s, R, t


def ate(est_stamps, est, gt_stamps, gt):
    """ATE figures; est/gt poses (N,4,4)."""
    pairs = nearest_pairs(est_stamps, gt_stamps)
    if len(pairs) < 3:
        raise ValueError("fewer than 3 associated poses")
    P = np.array([est[i][:3, 3] for i, _ in pairs])
    Q = np.array([gt[j][:3, 3] for _, j in pairs])
    out = {"pairs": len(pairs)}
    for name, ws in (("rigid", False), ("sim3", True)):
        s, R, t = umeyama(P, Q, ws)
        e = np.linalg.norm((s * (R @ P.T)).T + t - Q, axis=1)
        out[f"ate_{name}_rmse_m"] = float(np.sqrt((e ** 2).mean()))
        out[f"ate_{name}_mean_m"] = float(e.mean())
        out[f"ate_{name}_max_m"] = float(e.max())
        if ws:
            out["sim3_scale"] = float(s)
    out["gt_path_length_m"] = float(np.linalg.norm(np.diff(Q, axis=0), axis=1).sum())
    out["est_path_length_m"] = float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum())
    return out


def rpe(est_stamps, est, gt_stamps, gt, delta_s=1.0):
    """RPE over delta_s windows: translation RMSE (m), rotation mean (deg), TUM definition."""
    pairs = nearest_pairs(est_stamps, gt_stamps)
    st = np.array([est_stamps[i] for i, _ in pairs])
    E = [est[i] for i, _ in pairs]
    Gt = [gt[j] for _, j in pairs]
    te, re = [], []
    for a in range(len(st)):
        b = int(np.argmin(np.abs(st - (st[a] + delta_s))))
        if b <= a or abs(st[b] - st[a] - delta_s) > 0.1 * delta_s:
            continue
        dG = np.linalg.inv(Gt[a]) @ Gt[b]
        dE = np.linalg.inv(E[a]) @ E[b]
        err = np.linalg.inv(dG) @ dE
        te.append(np.linalg.norm(err[:3, 3]))
        re.append(np.degrees(np.arccos(np.clip((np.trace(err[:3, :3]) - 1) / 2, -1, 1))))
    if not te:
        return {}
    return {"rpe_window_s": delta_s, "rpe_trans_rmse_m": float(np.sqrt(np.mean(np.square(te)))),
            "rpe_rot_mean_deg": float(np.mean(re)), "rpe_pairs": len(te)}


# ---------------------------------------------------------------------------------------------
# running the network


class TorchRunner:
    def __init__(self, ckpt_path):
        import torch
        from .model import VONet
        self.torch = torch
        ck = torch.load(ckpt_path, map_location="cpu")
        self.net = VONet()
        self.net.load_state_dict(ck["model"])
        self.net.eval()
        self.reset()

    def reset(self):
        from .model import VONet
        self.state = list(VONet.zero_state(1))
        self.first = True

    def step(self, x):
        """x (1,3,H,W) normalised float32 -> (pose6 T_prev_cur or None for the first frame, depth)."""
        torch = self.torch
        with torch.no_grad():
            pose, depth, h, c, f1, f2, f3 = self.net(torch.from_numpy(x), *self.state)
        if self.first:  # first frame: keep only its features; the LSTM starts from zero state
            self.state = [f1, f2, f3, self.state[3], self.state[4]]
            self.first = False
            return None, depth[0, 0].numpy()
        self.state = [f1, f2, f3, h, c]
        return pose[0].numpy().astype(np.float64), depth[0, 0].numpy()


class OnnxRunner:
    """The exported model through OpenCV DNN (what the C++ side does)."""

    IN = ["image", "prev_f1", "prev_f2", "prev_f3", "h", "c"]
    OUT = ["pose6", "depth", "h_out", "c_out", "f1", "f2", "f3"]

    def __init__(self, onnx_path):
        self.net = cv2.dnn.readNetFromONNX(onnx_path)
        self.net.setPreferableBackend(cv2.dnn.DNN_BACKEND_OPENCV)
        self.net.setPreferableTarget(cv2.dnn.DNN_TARGET_CPU)
        self.reset()

    def reset(self):
        from .model import ENC_CH
        z = lambda *s: np.zeros(s, np.float32)
        self.state = [z(1, ENC_CH[0], C.HEIGHT // 2, C.WIDTH // 2), z(1, ENC_CH[1], C.HEIGHT // 4, C.WIDTH // 4),
                      z(1, ENC_CH[2], C.HEIGHT // 8, C.WIDTH // 8), z(1, C.HIDDEN), z(1, C.HIDDEN)]
        self.first = True

    def step(self, x):
        for name, v in zip(self.IN, [x] + self.state):
            self.net.setInput(np.ascontiguousarray(v, np.float32), name)
        pose, depth, h, c, f1, f2, f3 = [o.copy() for o in self.net.forward(self.OUT)]
        if self.first:
            self.state = [f1, f2, f3, self.state[3], self.state[4]]
            self.first = False
            return None, depth[0, 0]
        self.state = [f1, f2, f3, h, c]
        return pose[0].astype(np.float64), depth[0, 0]


def load_runner(model_path):
    return OnnxRunner(model_path) if model_path.endswith(".onnx") else TorchRunner(model_path)


def canonical_input(bgr, cam):
    """Source BGR (or grey) image -> (1,3,H,W) normalised network input."""
    x = cv2.cvtColor(to_canonical_rgb(bgr, cam), cv2.COLOR_BGR2RGB).astype(np.float32) / 255.0
    x = x * canonical_coverage(cam)[:, :, None]
    return np.ascontiguousarray(normalise(x.transpose(2, 0, 1))[None])


def run_sequence(runner, folder, start=0, end=None, every=1):
    """Run on the colour images of a TUM folder (depth is NOT used) -> (stamps, poses (N,4,4), info)."""
    with open(os.path.join(folder, "camera.yaml")) as f:
        cam = parse_camera_yaml(f.read(), folder)
    with open(os.path.join(folder, "rgb.txt")) as f:
        rgb = parse_list(f.read())
    if os.path.exists(os.path.join(folder, "depth.txt")):  # same frames as training used
        with open(os.path.join(folder, "depth.txt")) as f:
            frames = [(t, p) for t, p, _ in associate(rgb, parse_list(f.read()))]
    else:
        frames = rgb
    frames = frames[start:end][::every]
    runner.reset()
    T = np.eye(4)
    stamps, poses, ms = [], [], []
    for t, p in frames:
        img = cv2.imread(os.path.join(folder, p), cv2.IMREAD_COLOR)
        x = canonical_input(img, cam)
        t0 = time.perf_counter()
        pose6, _ = runner.step(x)
        ms.append(1000 * (time.perf_counter() - t0))
        if pose6 is not None:
            T = T @ pose6_to_T(pose6)
        stamps.append(t)
        poses.append(T.copy())
    return np.array(stamps), np.array(poses), {"frames": len(frames), "step_ms_median": float(np.median(ms))}


def evaluate_folder(model_path, spec, out=None, every=1):
    folder, start, end = parse_spec(spec)
    runner = load_runner(model_path)
    stamps, poses, info = run_sequence(runner, folder, start, end, every)
    if out:
        write_tum_trajectory(out, stamps, poses)
    res = {"sequence": spec, "model": os.path.basename(model_path), **info}
    gpath = os.path.join(folder, "groundtruth.txt")
    if os.path.exists(gpath):
        gs, gp = read_groundtruth(folder)
        res.update(ate(stamps, poses, gs, gp))
        res.update(rpe(stamps, poses, gs, gp))
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sequences", nargs="+", help="FOLDER[:START[:END]] (TUM layout)")
    ap.add_argument("--model", required=True, help="checkpoint (.pt) or exported .onnx")
    ap.add_argument("--out", help="trajectory file (one sequence) or folder (several)")
    ap.add_argument("--every", type=int, default=1, help="use every n-th frame")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--json", help="write the figures here")
    a = ap.parse_args(argv)
    cv2.setNumThreads(a.threads)
    try:
        import torch
        torch.set_num_threads(a.threads)
    except ImportError:
        pass
    results = []
    for spec in a.sequences:
        out = a.out
        if out and len(a.sequences) > 1:
            os.makedirs(out, exist_ok=True)
            out = os.path.join(out, os.path.basename(parse_spec(spec)[0].rstrip("/")) + ".txt")
        r = evaluate_folder(a.model, spec, out, a.every)
        results.append(r)
        print(json.dumps(r), flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
