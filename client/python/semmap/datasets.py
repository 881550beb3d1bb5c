"""Dataset folders as the CLI (`semmap ingest DIR`) reads them, for Client.ingest:

- TUM RGB-D layout: rgb.txt (and depth.txt) listing `timestamp path`, camera.yaml with width,
  height, fx, fy, cx, cy, depth_scale; depth associated to colour within 20 ms.
- KITTI odometry layout: image_0/NNNNNN.png, times.txt, calib.txt (P0).
- A plain image folder with a camera.yaml: *.png / *.jpg in name order, stamped at its fps.

Images are sent as their file bytes (the server decodes them). Errors raise SemmapError with
INVALID_ARGUMENT or NOT_FOUND naming the file.
"""
import os
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

import grpc
import numpy as np

from .errors import SemmapError
from .poses import pose_matrix
from .types import Camera

TUM_MAX_ASSOCIATION_S = 0.02
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")


@dataclass(frozen=True)
class DatasetFrame:
    stamp_s: float
    colour_path: str
    depth_path: Optional[str]


@dataclass(frozen=True)
class Dataset:
    kind: str  # "tum", "kitti", "images"
    dir: str
    camera: Camera
    depth_scale: float  # raw units per metre; 0 when the dataset has no depth
    frames: List[DatasetFrame]


def _invalid(message: str) -> SemmapError:
    return SemmapError(grpc.StatusCode.INVALID_ARGUMENT, message)


def _not_found(message: str) -> SemmapError:
    return SemmapError(grpc.StatusCode.NOT_FOUND, message)


def read_camera_yaml(path: str) -> Tuple[Camera, float, float]:
    """camera.yaml's flat `key: value  # comment` lines -> (camera, depth_scale, fps)."""
    if not os.path.isfile(path):
        raise _not_found(f"{path} does not exist")
    values: Dict[str, str] = {}
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            text = line.split("#", 1)[0].strip()
            if not text:
                continue
            key, sep, value = text.partition(":")
            key = key.strip()
            if not sep or key in values:
                raise _invalid(f"{path}:{number}: expected one 'key: value' per key")
            values[key] = value.strip()
    known = {"width", "height", "fx", "fy", "cx", "cy", "depth_scale", "distortion", "fps"}
    for key in values:
        if key not in known:
            raise _invalid(f"{path}: unknown key '{key}'")
    try:
        distortion = tuple(float(v) for v in values.get("distortion", "[0, 0, 0, 0, 0]")
                           .strip("[]").split(",") if v.strip())
        camera = Camera(int(values["width"]), int(values["height"]), float(values["fx"]),
                        float(values["fy"]), float(values["cx"]), float(values["cy"]),
                        distortion + (0.0,) * (5 - len(distortion)))
        return camera, float(values.get("depth_scale", 0)), float(values.get("fps", 30))
    except KeyError as missing:
        raise _invalid(f"{path}: needs {missing.args[0]}") from None
    except ValueError as bad:
        raise _invalid(f"{path}: {bad}") from None


def _read_list(directory: str, name: str) -> List[Tuple[float, str]]:
    path = os.path.join(directory, name)
    entries = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            fields = text.replace(",", " ").split()
            if len(fields) < 2:
                raise _invalid(f"{path}:{number}: expected 'timestamp path'")
            try:
                stamp = float(fields[0])
            except ValueError:
                raise _invalid(f"{path}:{number}: bad timestamp '{fields[0]}'") from None
            image = os.path.join(directory, fields[1])
            if not os.path.isfile(image):
                raise _not_found(f"{path}:{number}: listed image {image} does not exist")
            entries.append((stamp, image))
    entries.sort(key=lambda e: e[0])
    return entries


def _associate(colour: List[float], depth: List[float], max_s: float) -> List[Optional[int]]:
    """Greedy by smallest stamp difference, each depth used once (as the C++ client)."""
    depth_sorted = np.array(depth)
    candidates = []
    for i, stamp in enumerate(colour):
        if len(depth_sorted) == 0:
            break
        lo = np.searchsorted(depth_sorted, stamp - max_s)
        hi = np.searchsorted(depth_sorted, stamp + max_s, side="right")
        for j in range(lo, hi):
            difference = abs(depth_sorted[j] - stamp)
            if difference < max_s:
                candidates.append((difference, i, j))
    candidates.sort()
    partner: List[Optional[int]] = [None] * len(colour)
    used = set()
    for _, i, j in candidates:
        if partner[i] is None and j not in used:
            partner[i] = j
            used.add(j)
    return partner


def _open_tum(directory: str) -> Dataset:
    camera, depth_scale, _ = read_camera_yaml(os.path.join(directory, "camera.yaml"))
    colour = _read_list(directory, "rgb.txt")
    if not colour:
        raise _invalid(f"{directory}/rgb.txt lists no images")
    depth: List[Tuple[float, str]] = []
    if os.path.isfile(os.path.join(directory, "depth.txt")):
        if depth_scale <= 0:
            raise _invalid(f"{directory}/camera.yaml: depth_scale must be positive when "
                           "depth.txt is present")
        depth = _read_list(directory, "depth.txt")
    else:
        depth_scale = 0.0
    partner = _associate([c[0] for c in colour], [d[0] for d in depth], TUM_MAX_ASSOCIATION_S)
    frames = [DatasetFrame(stamp, path, depth[p][1] if p is not None else None)
              for (stamp, path), p in zip(colour, partner)]
    return Dataset("tum", directory, camera, depth_scale, frames)


def _open_kitti(directory: str) -> Dataset:
    import cv2  # only here: reading one image's size

    calib = os.path.join(directory, "calib.txt")
    p0 = None
    with open(calib, encoding="utf-8") as f:
        for line in f:
            if line.startswith("P0:"):
                p0 = [float(v) for v in line.split()[1:13]]
    if p0 is None or len(p0) != 12:
        raise _invalid(f"{calib}: needs a 'P0:' row of 12 numbers")
    with open(os.path.join(directory, "times.txt"), encoding="utf-8") as f:
        stamps = [float(line) for line in f if line.strip()]
    frames = []
    for i, stamp in enumerate(stamps):
        path = os.path.join(directory, "image_0", f"{i:06d}.png")
        if not os.path.isfile(path):
            raise _not_found(f"{path} does not exist (times.txt lists {len(stamps)} frames)")
        frames.append(DatasetFrame(stamp, path, None))
    if not frames:
        raise _invalid(f"{directory}/times.txt lists no frames")
    first = cv2.imread(frames[0].colour_path, cv2.IMREAD_UNCHANGED)
    if first is None:
        raise _invalid(f"{frames[0].colour_path} is not a readable image")
    camera = Camera(first.shape[1], first.shape[0], p0[0], p0[5], p0[2], p0[6])
    return Dataset("kitti", directory, camera, 0.0, frames)


def _open_image_folder(directory: str) -> Dataset:
    camera, _, fps = read_camera_yaml(os.path.join(directory, "camera.yaml"))
    names = sorted(n for n in os.listdir(directory) if n.lower().endswith(IMAGE_SUFFIXES))
    if not names:
        raise _invalid(f"{directory} holds no .png / .jpg images")
    frames = [DatasetFrame(i / fps, os.path.join(directory, n), None) for i, n in enumerate(names)]
    return Dataset("images", directory, camera, 0.0, frames)


def open_dataset(directory: str) -> Dataset:
    """Recognises the layout of `directory` (see the module's docstring)."""
    if not os.path.isdir(directory):
        raise _not_found(f"{directory}: no such dataset directory")
    if os.path.isfile(os.path.join(directory, "rgb.txt")):
        return _open_tum(directory)
    if os.path.isdir(os.path.join(directory, "image_0")) and os.path.isfile(
            os.path.join(directory, "times.txt")):
        return _open_kitti(directory)
    if os.path.isfile(os.path.join(directory, "camera.yaml")):
        return _open_image_folder(directory)
    raise _invalid(f"{directory}: not a dataset: expected rgb.txt (TUM RGB-D layout), image_0/ "
                   "and times.txt (KITTI odometry layout), or images next to a camera.yaml")


def read_tum_trajectory(path: str) -> np.ndarray:
    """A TUM trajectory file (`stamp tx ty tz qx qy qz qw` per line) as an N x 8 array,
    sorted by stamp."""
    if not os.path.isfile(path):
        raise _not_found(f"{path} does not exist")
    rows = []
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            try:
                row = [float(v) for v in text.split()]
            except ValueError:
                raise _invalid(f"{path}:{number}: not a number") from None
            if len(row) != 8:
                raise _invalid(f"{path}:{number}: expected 8 values, got {len(row)}")
            rows.append(row)
    trajectory = np.array(rows, dtype=np.float64).reshape(-1, 8)
    return trajectory[np.argsort(trajectory[:, 0], kind="stable")]


class PoseLookup:
    """T_world_camera at a frame's stamp: the trajectory's nearest pose within `max_s`."""

    def __init__(self, trajectory: np.ndarray, max_s: float = TUM_MAX_ASSOCIATION_S):
        self._trajectory = trajectory
        self._max_s = max_s

    def at(self, stamp_s: float) -> Optional[np.ndarray]:
        stamps = self._trajectory[:, 0]
        if len(stamps) == 0:
            return None
        i = int(np.searchsorted(stamps, stamp_s))
        best = min((j for j in (i - 1, i) if 0 <= j < len(stamps)),
                   key=lambda j: abs(stamps[j] - stamp_s))
        if abs(stamps[best] - stamp_s) > self._max_s:
            return None
        return pose_matrix(self._trajectory[best, 1:4], self._trajectory[best, 4:8])
