"""The training loader must never see poses: every file access goes through the guarded opener."""
import ast
import builtins
import io
import os

import cv2
import numpy as np
import pytest

from semmap_vo import data as D

TRAINING_MODULES = ["data.py", "train.py", "losses.py", "model.py", "geometry.py", "config.py", "export.py"]
PKG = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "semmap_vo")


def make_folder(root, n=12, name="seq"):
    """A tiny TUM-layout folder (textured noise, constant-ish depth) with a booby-trapped
    groundtruth.txt."""
    f = root / name
    (f / "rgb").mkdir(parents=True)
    (f / "depth").mkdir()
    rng = np.random.default_rng(0)
    rgb_rows, d_rows = [], []
    for i in range(n):
        t = 100 + i / 30
        img = cv2.GaussianBlur(rng.integers(0, 255, (120, 160, 3), dtype=np.uint8), (5, 5), 0)
        cv2.imwrite(str(f / "rgb" / f"{t:.6f}.png"), img)
        cv2.imwrite(str(f / "depth" / f"{t:.6f}.png"), np.full((120, 160), 10000, np.uint16))
        rgb_rows.append(f"{t:.6f} rgb/{t:.6f}.png")
        d_rows.append(f"{t + 0.005:.6f} depth/{t:.6f}.png")
    (f / "rgb.txt").write_text("# colour\n" + "\n".join(rgb_rows) + "\n")
    (f / "depth.txt").write_text("# depth\n" + "\n".join(d_rows) + "\n")
    (f / "camera.yaml").write_text("width: 160\nheight: 120\nfx: 131.25\nfy: 131.25\ncx: 79.5\ncy: 59.5\n"
                                   "depth_scale: 5000\ndistortion: [0, 0, 0, 0, 0]\n")
    return f


@pytest.mark.parametrize("name", ["groundtruth.txt", "GroundTruth.txt", "groundtruth.txt.orig", "poses.txt",
                                  "00_poses.txt", "trajectory.txt", "traj_est.txt", "odometry.csv",
                                  "gt_poses.npy", "notes.txt", "times.txt", "calib.txt", "data.npz"])
def test_guarded_open_refuses(tmp_path, name):
    p = tmp_path / name
    p.write_text("0 0 0 0 0 0 0 1\n")
    with pytest.raises(D.ForbiddenFileError):
        D.guarded_open(str(p))


def test_guarded_open_allows_inputs(tmp_path):
    f = make_folder(tmp_path)
    for n in ("rgb.txt", "depth.txt", "camera.yaml"):
        D.guarded_open(str(f / n)).close()
    with pytest.raises(ValueError):
        D.guarded_open(str(f / "rgb.txt"), "w")


@pytest.mark.parametrize("folder", ["tum_fr3_teddy_200", "rgbd_dataset_freiburg3_teddy", "rgbd_dataset_freiburg1_xyz",
                                    "tum_fr1_xyz_pairs", "fr1_desk"])
def test_evaluation_and_freiburg1_sequences_are_refused(tmp_path, folder):
    f = make_folder(tmp_path, name=folder)
    with pytest.raises(D.ForbiddenFileError):
        D.load_sequence(str(f))
    with pytest.raises(D.ForbiddenFileError):
        D.guarded_open(str(f / "rgb.txt"))


def test_real_evaluation_sequence_is_refused():
    teddy = os.path.join(os.path.dirname(PKG), "..", "..", "shared", "data", "tum_fr3_teddy_200")
    with pytest.raises(D.ForbiddenFileError):
        D.load_sequence(teddy)


def test_loads_with_unreadable_groundtruth(tmp_path, monkeypatch):
    """groundtruth.txt is a directory (unreadable as a file) and any open() of a ground-truth path
    blows up: the loader and the sampler still work, and never touched it."""
    f = make_folder(tmp_path)
    (f / "groundtruth.txt").mkdir()
    (f / "groundtruth.txt" / "x").write_text("trap")
    (f / "poses.txt").write_text("trap")
    opened = []
    real_open, real_io_open = builtins.open, io.open

    def trap(path, *a, **k):
        s = os.fspath(path) if not isinstance(path, int) else ""
        opened.append(s)
        if "groundtruth" in s or "poses" in s:
            raise AssertionError(f"loader opened {s}")
        return real_open(path, *a, **k)

    monkeypatch.setattr(builtins, "open", trap)
    monkeypatch.setattr(io, "open", trap)
    seq = D.load_sequence(str(f), cache_dir=str(tmp_path / "cache"))
    assert len(seq) == 12 and seq.rgb.shape[1:] == (96, 128, 3)
    assert np.all(seq.depth[:, 48, 64] == np.float16(2.0))
    sampler = D.ChunkSampler([seq], batch=2, length=3, strides=(1, 2))
    b = sampler.next()
    assert b["image"].shape == (2, 4, 3, 96, 128)
    assert not any("groundtruth" in p or "poses" in p for p in opened)
    # everything opened is a whitelisted input (or the frame cache)
    for p in opened:
        base = os.path.basename(p)
        assert base in ("rgb.txt", "depth.txt", "camera.yaml") or base.endswith((".png", ".npz")), p


def test_training_code_does_not_import_evaluation_or_read_files_directly():
    """Only evaluate.py reads ground truth: no training module imports it, and only data.py opens files
    (through guarded_open)."""
    for name in TRAINING_MODULES:
        src = open(os.path.join(PKG, name)).read()
        tree = ast.parse(src)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                assert node.module is None or "evaluate" not in node.module, f"{name} imports evaluate"
                assert not any(a.name == "evaluate" for a in node.names), f"{name} imports evaluate"
            if isinstance(node, ast.Import):
                assert not any("evaluate" in a.name for a in node.names), f"{name} imports evaluate"
        if name != "data.py":  # data.py names it only to refuse it
            assert "groundtruth" not in src.lower(), f"{name} mentions groundtruth"
    data_src = open(os.path.join(PKG, "data.py")).read()
    # the only bare open() in data.py is the one inside guarded_open
    assert data_src.count("open(path, mode)") == 1
    assert data_src.count(" open(") == 1
    assert "cv2.imread(" not in data_src and "np.loadtxt" not in data_src


def test_canonical_resampling_matches_the_affine():
    """A source image with a dot at (u, v) lands where the documented affine says."""
    cam = {"width": 640, "height": 480, "fx": 535.4, "fy": 539.2, "cx": 320.1, "cy": 247.6}
    img = np.zeros((480, 640, 3), np.uint8)
    u, v = 400.0, 300.0
    cv2.circle(img, (int(u), int(v)), 6, (255, 255, 255), -1)
    out = D.to_canonical_rgb(img, cam)[..., 0].astype(np.float64)
    ys, xs = np.mgrid[0:out.shape[0], 0:out.shape[1]]
    cu, cv_ = (xs * out).sum() / out.sum(), (ys * out).sum() / out.sum()
    from semmap_vo import config as C
    eu = C.FC / cam["fx"] * (u - cam["cx"]) + C.CXC
    ev = C.FC / cam["fy"] * (v - cam["cy"]) + C.CYC
    assert abs(cu - eu) < 0.15 and abs(cv_ - ev) < 0.15
    # a camera narrower than the canonical one leaves a black, uncovered border
    kitti = {"width": 1241, "height": 376, "fx": 718.856, "fy": 718.856, "cx": 607.19, "cy": 185.22}
    cover = D.canonical_coverage(kitti)
    assert cover[48].all() and not cover[0].any()
