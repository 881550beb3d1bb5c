"""Training data: TUM-layout RGB-D folders -> canonical-camera frames -> recurrent chunks.

NO POSES. The loader reads only rgb.txt, depth.txt, camera.yaml and the image files they list,
and every file access goes through `guarded_open`, which refuses ground truth, pose and
trajectory files, any file outside that whitelist, the evaluation sequence (TUM fr3/teddy) and
any TUM freiburg1 sequence. Nothing in this module (or in train.py, losses.py, model.py) reads
ground truth; only evaluate.py does, and the trainer does not import it.
"""
import hashlib
import os
import re

import cv2
import numpy as np

from . import config as C

# ---------------------------------------------------------------------------------------------
# The guard


class ForbiddenFileError(PermissionError):
    """Raised when training code asks for ground truth, poses or an evaluation-only sequence."""


_FORBIDDEN_NAME = re.compile(r"(groundtruth|ground_truth|pose|traj|odometry|\.orig$)", re.I)
_ALLOWED_NAMES = {"rgb.txt", "depth.txt", "camera.yaml"}
_ALLOWED_EXT = {".png", ".jpg", ".jpeg"}
# The evaluation sequence (any copy of TUM fr3/teddy) and every TUM freiburg1 sequence.
_FORBIDDEN_DATASET = re.compile(r"(teddy|freiburg1|(^|[_\-])fr1([_\-]|$))", re.I)


def check_dataset_allowed(folder):
    """Raise ForbiddenFileError when a dataset folder may not be used for training."""
    for part in os.path.abspath(folder).split(os.sep):
        if _FORBIDDEN_DATASET.search(part):
            raise ForbiddenFileError(
                f"refusing '{folder}': '{part}' is an evaluation-only sequence (TUM fr3/teddy) or a TUM "
                "freiburg1 sequence; those are never used for training")


def check_path_allowed(path):
    base = os.path.basename(path)
    if _FORBIDDEN_NAME.search(base):
        raise ForbiddenFileError(f"refusing to open '{path}': ground truth / pose files are not training inputs")
    ext = os.path.splitext(base)[1].lower()
    if base not in _ALLOWED_NAMES and ext not in _ALLOWED_EXT:
        raise ForbiddenFileError(f"refusing to open '{path}': the loader reads only rgb.txt, depth.txt, "
                                 "camera.yaml and image files")
    check_dataset_allowed(os.path.dirname(path) or ".")


def guarded_open(path, mode="rb"):
    """The loader's only way to open a file (read-only)."""
    if any(m in mode for m in "wax+"):
        raise ValueError("guarded_open is read-only")
    check_path_allowed(path)
    return open(path, mode)


def _read_bytes(path):
    with guarded_open(path, "rb") as f:
        return f.read()


def _read_text(path):
    with guarded_open(path, "r") as f:
        return f.read()


# ---------------------------------------------------------------------------------------------
# Folder reading


def parse_camera_yaml(text, where="camera.yaml"):
    """camera.yaml text -> dict(width, height, fx, fy, cx, cy, depth_scale, distortion)."""
    cam = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if ":" not in line:
            continue
        k, v = (s.strip() for s in line.split(":", 1))
        if k == "distortion":
            cam[k] = [float(x) for x in v.strip("[]").split(",") if x.strip()]
        elif v:
            cam[k] = float(v)
    for k in ("width", "height", "fx", "fy", "cx", "cy", "depth_scale"):
        if k not in cam:
            raise ValueError(f"{where}: missing '{k}'")
    if any(abs(d) > 1e-9 for d in cam.get("distortion", [])):
        raise ValueError(f"{where}: distorted cameras are not supported by the canonical resampling")
    return cam


def parse_list(text):
    """rgb.txt / depth.txt text -> [(stamp, relative path)]."""
    rows = []
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        t, p = line.split()[:2]
        rows.append((float(t), p))
    return rows


def read_camera_yaml(folder):
    return parse_camera_yaml(_read_text(os.path.join(folder, "camera.yaml")), f"{folder}/camera.yaml")


def read_list(folder, name):
    return parse_list(_read_text(os.path.join(folder, name)))


def nearest_pairs(a, b, max_dt=0.02):
    """Index pairs (i, j): for each stamp a_i the nearest b_j, kept when |a_i - b_j| < max_dt."""
    b = np.asarray(b, np.float64)
    if b.size == 0:
        return []
    pairs = []
    for i, t in enumerate(a):
        j = int(np.argmin(np.abs(b - t)))
        if abs(b[j] - t) < max_dt:
            pairs.append((i, j))
    return pairs


def associate(rgb, depth, max_dt=0.02):
    """Nearest-stamp association of two sorted (stamp, path) lists -> [(stamp, rgb, depth)]."""
    pairs = nearest_pairs([t for t, _ in rgb], [t for t, _ in depth], max_dt)
    return [(rgb[i][0], rgb[i][1], depth[j][1]) for i, j in pairs]


def decode_image(path, flags):
    buf = np.frombuffer(_read_bytes(path), np.uint8)
    img = cv2.imdecode(buf, flags)
    if img is None:
        raise ValueError(f"cannot decode {path}")
    return img


# ---------------------------------------------------------------------------------------------
# Canonical camera resampling (the C++ side must do exactly this; see config.py and the JSON)


def canonical_affine(cam):
    """(sx, sy, tx, ty): resize by (sx, sy) with INTER_AREA, then translate by (tx, ty)."""
    sx, sy = C.FC / cam["fx"], C.FC / cam["fy"]
    tx = 0.5 - 0.5 * sx - sx * cam["cx"] + C.CXC
    ty = 0.5 - 0.5 * sy - sy * cam["cy"] + C.CYC
    return sx, sy, tx, ty


def to_canonical_rgb(img, cam):
    """Source colour (H,W,3) uint8 (any channel order) or grey -> (HEIGHT, WIDTH, 3) uint8."""
    if img.ndim == 2:
        img = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    sx, sy, tx, ty = canonical_affine(cam)
    small = cv2.resize(img, (0, 0), fx=sx, fy=sy, interpolation=cv2.INTER_AREA)
    M = np.array([[1, 0, tx], [0, 1, ty]], np.float64)
    return cv2.warpAffine(small, M, (C.WIDTH, C.HEIGHT), flags=cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def canonical_coverage(cam):
    """(HEIGHT, WIDTH) bool: canonical pixels whose ray falls inside the source image."""
    u = (np.arange(C.WIDTH) - C.CXC) * cam["fx"] / C.FC + cam["cx"]
    v = (np.arange(C.HEIGHT) - C.CYC) * cam["fy"] / C.FC + cam["cy"]
    cu = (u >= 0) & (u <= cam["width"] - 1)
    cv_ = (v >= 0) & (v <= cam["height"] - 1)
    return cv_[:, None] & cu[None, :]


def to_canonical_depth(depth_raw, cam):
    """Source raw depth (uint16) -> (HEIGHT, WIDTH) float32 metres (0 = invalid), nearest sample."""
    u = (np.arange(C.WIDTH, dtype=np.float32) - C.CXC) * cam["fx"] / C.FC + cam["cx"]
    v = (np.arange(C.HEIGHT, dtype=np.float32) - C.CYC) * cam["fy"] / C.FC + cam["cy"]
    mx, my = np.meshgrid(u, v)
    d = depth_raw.astype(np.float32) / cam["depth_scale"]
    out = cv2.remap(d, mx.astype(np.float32), my.astype(np.float32), cv2.INTER_NEAREST,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    out[(out < C.DMIN) | (out > C.DMAX)] = 0
    return out


# ---------------------------------------------------------------------------------------------
# Sequences


class Sequence:
    """One training sequence in the canonical camera, held in memory.

    rgb (N, H, W, 3) uint8 RGB, depth (N, H, W) float16 metres (0 invalid), cover (H, W) bool,
    stamps (N,) float64. Built from the folder (slow) or from the cache (fast).
    """

    def __init__(self, name, rgb, depth, cover, stamps, cache_path=None):
        self.name, self.rgb, self.depth, self.cover, self.stamps = name, rgb, depth, cover, stamps
        self.cache_path = cache_path
        self.teacher = None  # {stride: (pose6 (N, 6) T_t_{t+stride}, ok (N,) bool)}, see teacher_motions

    def __len__(self):
        return len(self.stamps)


def parse_spec(spec):
    """'FOLDER[:START[:END]]' -> (folder, start, end) (frame indices after association)."""
    m = re.match(r"^(.*?)(?::(-?\d*)(?::(-?\d*))?)?$", spec)
    folder = m.group(1)
    start = int(m.group(2)) if m.group(2) else 0
    end = int(m.group(3)) if m.group(3) else None
    return folder, start, end


def load_sequence(spec, cache_dir=None, verbose=True):
    """Load a TUM-layout folder (optionally a frame range) into the canonical camera (cached)."""
    folder, start, end = parse_spec(spec)
    folder = os.path.abspath(folder)
    check_dataset_allowed(folder)
    cam = read_camera_yaml(folder)
    if cam["depth_scale"] <= 0:
        raise ValueError(f"{folder}: no depth (depth_scale 0); training needs depth")
    rgb_list = read_list(folder, "rgb.txt")
    depth_list = read_list(folder, "depth.txt")
    assoc = associate(rgb_list, depth_list)[start:end]
    if len(assoc) < 3:
        raise ValueError(f"{folder}: fewer than 3 associated frames in [{start}:{end}]")
    name = f"{os.path.basename(folder)}[{start}:{'' if end is None else end}]"
    cache_dir = cache_dir or os.path.join(C.CACHE_DIR, "frames")
    key = hashlib.sha1(repr((folder, start, end, C.WIDTH, C.HEIGHT, C.FC, C.DMIN, C.DMAX,
                             [a[1] for a in assoc], sorted(cam.items()), 2)).encode()).hexdigest()[:16]
    cpath = os.path.join(cache_dir, f"{os.path.basename(folder)}-{key}.npz")
    if os.path.exists(cpath):
        z = np.load(cpath)
        return Sequence(name, z["rgb"], z["depth"], z["cover"], z["stamps"], cpath)
    if verbose:
        print(f"data: converting {name} ({len(assoc)} frames) to {C.WIDTH}x{C.HEIGHT} canonical", flush=True)
    n = len(assoc)
    rgb = np.zeros((n, C.HEIGHT, C.WIDTH, 3), np.uint8)
    depth = np.zeros((n, C.HEIGHT, C.WIDTH), np.float16)
    for i, (_, rp, dp) in enumerate(assoc):
        bgr = decode_image(os.path.join(folder, rp), cv2.IMREAD_COLOR)
        rgb[i] = cv2.cvtColor(to_canonical_rgb(bgr, cam), cv2.COLOR_BGR2RGB)
        draw = decode_image(os.path.join(folder, dp), cv2.IMREAD_UNCHANGED)
        depth[i] = to_canonical_depth(draw, cam)
    cover = canonical_coverage(cam)
    stamps = np.array([a[0] for a in assoc])
    os.makedirs(cache_dir, exist_ok=True)
    tmp = cpath + ".tmp.npz"
    np.savez(tmp, rgb=rgb, depth=depth, cover=cover, stamps=stamps)
    os.replace(tmp, cpath)
    return Sequence(name, rgb, depth, cover, stamps, cpath)


# ---------------------------------------------------------------------------------------------
# Teacher motions: classical RGB-D odometry on the training frames (images + sensor depth only)


def rgbd_odometry(grey_a, depth_a, grey_b, depth_b, cover):
    """OpenCV's RGB-D ICP odometry (photometric + point-to-plane ICP) between two canonical frames.
    Returns T_a_b (4x4, X_a = T_a_b X_b) or None when it fails or the motion is implausible."""
    odo = cv2.rgbd.RgbdICPOdometry_create()
    odo.setCameraMatrix(np.array(C.canonical_K(), np.float64))
    odo.setMinDepth(0.2)
    odo.setMaxDepth(10.0)
    odo.setMaxDepthDiff(0.07)
    nan = lambda d: np.where(d > 0, d, np.nan).astype(np.float32)
    m = cover.astype(np.uint8) * 255
    ok, Rt = odo.compute(grey_a, nan(depth_a), m, grey_b, nan(depth_b), m)
    if not ok or not np.all(np.isfinite(Rt)):
        return None
    T = np.linalg.inv(Rt)  # compute() returns the motion of b's points into a's frame, inverted
    ang = np.degrees(np.arccos(np.clip((np.trace(T[:3, :3]) - 1) / 2, -1, 1)))
    if np.linalg.norm(T[:3, 3]) > 0.3 or ang > 20:
        return None
    return T


def teacher_motions(seq, strides=(1, 2, 3), verbose=True):
    """Pseudo-labels for the pose head's warm-up: T_t_{t+s} from RGB-D odometry for every frame t
    and stride s, computed from the sequence's own images and sensor depth (no ground truth),
    cached next to the frame cache. Sets and returns seq.teacher."""
    key = os.path.splitext(seq.cache_path)[0] + "-teacher-" + "".join(map(str, strides)) + ".npz" \
        if seq.cache_path else None
    if key and os.path.exists(key):
        z = np.load(key)
        seq.teacher = {s: (z[f"pose_{s}"], z[f"ok_{s}"]) for s in strides}
        return seq.teacher
    if verbose:
        print(f"data: RGB-D odometry teacher for {seq.name}", flush=True)
    grey = [cv2.cvtColor(im, cv2.COLOR_RGB2GRAY) for im in seq.rgb]
    depth = seq.depth.astype(np.float32)
    out = {}
    n = len(seq)
    for s in strides:
        pose = np.zeros((n, 6), np.float32)
        ok = np.zeros(n, bool)
        for t in range(n - s):
            T = rgbd_odometry(grey[t], depth[t], grey[t + s], depth[t + s], seq.cover)
            if T is not None:
                pose[t, :3] = T[:3, 3]
                pose[t, 3:] = cv2.Rodrigues(T[:3, :3])[0].ravel()
                ok[t] = True
        out[s] = (pose, ok)
    if key:
        tmp = key + ".tmp.npz"
        np.savez(tmp, **{f"pose_{s}": out[s][0] for s in strides}, **{f"ok_{s}": out[s][1] for s in strides})
        os.replace(tmp, key)
    seq.teacher = out
    return out


def mirror_pose6(p):
    """The motion seen in the horizontally mirrored images: T' = S T S, S = diag(-1, 1, 1)."""
    return p * np.array([-1, 1, 1, 1, -1, -1], p.dtype)


def invert_pose6(p):
    """pose6 of the inverse motion (rows)."""
    out = np.zeros_like(p)
    for i, q in enumerate(p):
        R = cv2.Rodrigues(q[3:6].astype(np.float64))[0]
        out[i, :3] = -R.T @ q[:3]
        out[i, 3:] = -q[3:6]
    return out


# ---------------------------------------------------------------------------------------------
# Recurrent chunk sampler (truncated back-propagation through time)


def normalise(rgb01):
    """(…, 3, H, W) float in [0,1] -> network input."""
    mean = np.array(C.MEAN, np.float32).reshape(3, 1, 1)
    std = np.array(C.STD, np.float32).reshape(3, 1, 1)
    return (rgb01 - mean) / std


class _Stream:
    __slots__ = ("seq", "pos", "direction", "stride", "flip", "gain", "contrast", "grey", "chunks_left", "fresh")


class ChunkSampler:
    """B parallel streams, each walking through one sequence in chunks of L+1 frames.

    Consecutive chunks of a stream share one frame (the last of one is the first of the next), so
    the trainer can carry the LSTM state across chunks (detached): the LSTM sees long-running
    states like at inference, not only fresh ones. A stream restarts (fresh state, new sequence,
    new augmentation) after a random number of chunks or at the end of its sequence.
    Augmentation, fixed per stream so geometry stays valid over time: time reversal, horizontal
    flip (the canonical camera is symmetric, so the intrinsics are unchanged), frame stride,
    brightness/contrast/per-channel gain, greyscale.
    """

    def __init__(self, sequences, weights=None, batch=8, length=5, max_chunks=8, strides=(1, 1, 2, 3),
                 augment=True, seed=0):
        self.seqs = [s for s in sequences if len(s) > max(strides) * length + 1]
        if not self.seqs:
            raise ValueError("no sequence is long enough for the chunk length")
        w = np.array(weights if weights is not None else [len(s) for s in sequences], np.float64)
        w = np.array([wi for wi, s in zip(w, sequences) if len(s) > max(strides) * length + 1])
        self.p = w / w.sum()
        self.B, self.L, self.max_chunks, self.strides, self.augment = batch, length, max_chunks, strides, augment
        self.rng = np.random.default_rng(seed)
        self.streams = [self._new_stream() for _ in range(batch)]

    def _new_stream(self):
        r = self.rng
        s = _Stream()
        s.seq = self.seqs[r.choice(len(self.seqs), p=self.p)]
        s.stride = int(r.choice(self.strides)) if self.augment else 1
        s.direction = int(r.choice([-1, 1])) if self.augment else 1
        span = s.stride * self.L
        s.pos = int(r.integers(0, len(s.seq) - span)) if s.direction > 0 else int(r.integers(span, len(s.seq)))
        s.flip = bool(r.random() < 0.5) if self.augment else False
        s.gain = r.uniform(0.9, 1.1, 3).astype(np.float32) * r.uniform(0.7, 1.3) if self.augment else np.ones(3, np.float32)
        s.contrast = float(r.uniform(0.7, 1.3)) if self.augment else 1.0
        s.grey = bool(r.random() < 0.15) if self.augment else False
        if s.grey:  # a grey camera: one gain for the three (identical) channels
            s.gain = np.full(3, s.gain.mean(), np.float32)
        s.chunks_left = int(r.integers(1, self.max_chunks + 1))
        s.fresh = True
        return s

    def state_dict(self):
        return {"rng": self.rng.bit_generator.state}

    def load_state_dict(self, d):
        self.rng.bit_generator.state = d["rng"]
        self.streams = [self._new_stream() for _ in range(self.B)]

    def next(self):
        """-> dict(rgb (B,L+1,3,H,W) float [0,1], image (normalised), depth (B,L+1,1,H,W) metres,
        cover (B,1,1,H,W), reset (B,) bool: the chunk starts a fresh stream (zero LSTM state))."""
        B, L = self.B, self.L
        H, W = C.HEIGHT, C.WIDTH
        rgb = np.zeros((B, L + 1, 3, H, W), np.float32)
        depth = np.zeros((B, L + 1, 1, H, W), np.float32)
        cover = np.zeros((B, 1, 1, H, W), np.float32)
        reset = np.zeros(B, bool)
        teacher = np.zeros((B, L, 6), np.float32)
        teacher_ok = np.zeros((B, L), np.float32)
        for b in range(B):
            s = self.streams[b]
            span = s.stride * L
            end = s.pos + s.direction * span
            if s.chunks_left <= 0 or end < 0 or end >= len(s.seq):
                s = self.streams[b] = self._new_stream()
                end = s.pos + s.direction * span
            reset[b] = s.fresh
            s.fresh = False
            idx = s.pos + s.direction * s.stride * np.arange(L + 1)
            x = s.seq.rgb[idx].astype(np.float32) / 255.0  # (L+1,H,W,3)
            d = s.seq.depth[idx].astype(np.float32)
            cv_ = s.seq.cover.astype(np.float32)
            if s.grey:
                x = np.repeat(x @ np.array([[0.299], [0.587], [0.114]], np.float32), 3, -1)
            x = np.clip((x - 0.5) * s.contrast + 0.5, 0, 1) * s.gain
            x = np.clip(x, 0, 1) * cv_[None, :, :, None]  # outside the source stays black
            if s.seq.teacher is not None and s.stride in s.seq.teacher:
                tp, tok = s.seq.teacher[s.stride]
                if s.direction > 0:  # pair k: frames idx[k] -> idx[k+1] = idx[k] + stride
                    teacher[b], teacher_ok[b] = tp[idx[:-1]], tok[idx[:-1]]
                else:  # reversed: idx[k+1] = idx[k] - stride, motion = inverse of T_{idx[k+1]}_{idx[k]}
                    teacher[b], teacher_ok[b] = invert_pose6(tp[idx[1:]]), tok[idx[1:]]
                if s.flip:
                    teacher[b] = mirror_pose6(teacher[b])
            if s.flip:
                x, d, cv_ = x[:, :, ::-1], d[:, :, ::-1], cv_[:, ::-1]
            rgb[b] = x.transpose(0, 3, 1, 2)
            depth[b, :, 0] = d
            cover[b, 0, 0] = cv_
            s.pos = int(end)
            s.chunks_left -= 1
        return {"rgb": rgb, "image": normalise(rgb), "depth": depth, "cover": cover, "reset": reset,
                "teacher": teacher, "teacher_ok": teacher_ok}
