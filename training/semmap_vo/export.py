"""ONNX export of one recurrent step, for OpenCV 4.6 DNN (the C++ side), plus its JSON sidecar.

usage: python3 -m semmap_vo.export CKPT.pt --out models/vo/semmap_vo.onnx [--card-json extra.json]

The graph: inputs  image (1,3,H,W), prev_f2, prev_f3 (previous frame's features), h, c (1,HIDDEN)
           outputs pose6 (1,6), depth (1,1,H,W), h_out, c_out, f1, f2, f3 (fed back as prev_f1..3)
Opset 11 (OpenCV 4.6 imports it); the LSTM is an explicit cell (Gemm, Slice, Sigmoid, Tanh, Mul, Add).
"""
import argparse
import copy
import hashlib
import json
import os
import sys
import time
import warnings

import cv2
import numpy as np
import torch

from . import config as C
from .model import ENC_CH, INPUT_NAMES, OUTPUT_NAMES, VONet

OPSET = 11


def fused_copy(net):
    """An eval-mode copy with every Conv + BatchNorm pair folded into one Conv."""
    from torch.nn.utils.fusion import fuse_conv_bn_eval
    m = copy.deepcopy(net).eval()
    for mod in m.modules():
        if isinstance(mod, torch.nn.Sequential):
            for i in range(len(mod) - 1):
                if isinstance(mod[i], torch.nn.Conv2d) and isinstance(mod[i + 1], torch.nn.BatchNorm2d):
                    mod[i] = fuse_conv_bn_eval(mod[i], mod[i + 1])
                    mod[i + 1] = torch.nn.Identity()
    return m


def export_onnx(net, path, opset=OPSET):
    """Export one step (BatchNorm folded). The export runs in PRESERVE mode with the top module
    flagged as training (every submodule is in eval mode): torch then merges only initialisers that
    share storage, not equal-valued ones, which it would turn into Identity nodes that OpenCV 4.6
    cannot import (equal values happen, e.g. zero biases of a fresh network)."""
    m = fused_copy(net)
    m.training = True
    dummy = (torch.zeros(1, 3, C.HEIGHT, C.WIDTH),) + VONet.zero_state(1)
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(m, dummy, path, input_names=INPUT_NAMES, output_names=OUTPUT_NAMES,
                          opset_version=opset, training=torch.onnx.TrainingMode.PRESERVE,
                          do_constant_folding=False)
    return path


def load_cv_net(path, threads=1):
    cv2.setNumThreads(threads)
    net = cv2.dnn.readNetFromONNX(path)
    net.setPreferableBackend(cv2.dnn.DNN_BACKEND_OPENCV)
    net.setPreferableTarget(cv2.dnn.DNN_TARGET_CPU)
    return net


def cv_forward(cvnet, inputs):
    for name, v in zip(INPUT_NAMES, inputs):
        cvnet.setInput(np.ascontiguousarray(v, np.float32), name)
    return [o.copy() for o in cvnet.forward(OUTPUT_NAMES)]


def check_onnx(net, path, steps=4, seed=0, images=None):
    """Run PyTorch and cv2.dnn side by side over `steps` recurrent steps (state fed back from each
    side's own outputs); return the max abs difference over all outputs and steps."""
    net = net.eval()
    cvnet = load_cv_net(path)
    g = torch.Generator().manual_seed(seed)
    st_t = list(VONet.zero_state(1))
    st_c = [s.numpy() for s in st_t]
    worst = 0.0
    for k in range(steps):
        img = images[k] if images is not None else torch.randn(1, 3, C.HEIGHT, C.WIDTH, generator=g)
        with torch.no_grad():
            out_t = [o.numpy() for o in net(img, *st_t)]
        out_c = cv_forward(cvnet, [img.numpy()] + st_c)
        for a, b in zip(out_t, out_c):
            if a.shape != b.shape:
                raise AssertionError(f"shape mismatch {a.shape} vs {b.shape}")
            worst = max(worst, float(np.abs(a - b).max()))
        st_t = [torch.from_numpy(out_t[i]) for i in (4, 5, 6, 2, 3)]
        st_c = [out_c[i] for i in (4, 5, 6, 2, 3)]
    return worst


def time_cv(path, runs=50, threads=1):
    """Median ms of one step in cv2.dnn with `threads` threads."""
    cvnet = load_cv_net(path, threads)
    inputs = [np.random.default_rng(0).standard_normal((1, 3, C.HEIGHT, C.WIDTH)).astype(np.float32)] + \
        [s.numpy() for s in VONet.zero_state(1)]
    for _ in range(5):
        cv_forward(cvnet, inputs)
    ts = []
    for _ in range(runs):
        t = time.perf_counter()
        cv_forward(cvnet, inputs)
        ts.append(1000 * (time.perf_counter() - t))
    return float(np.median(ts)), float(np.percentile(ts, 90))


def sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for blk in iter(lambda: f.read(1 << 20), b""):
            h.update(blk)
    return h.hexdigest()


def sidecar(onnx_path, extra=None):
    """The JSON the C++ side reads: input preprocessing, I/O names and shapes, conventions."""
    d = {
        "format": "semmap_vo/1",
        "onnx": os.path.basename(onnx_path),
        "sha256": sha256(onnx_path),
        "opset": OPSET,
        "input": {
            "width": C.WIDTH, "height": C.HEIGHT, "channels": "RGB", "layout": "NCHW float32",
            "normalisation": {"formula": "x = (rgb / 255 - mean) / std", "mean": list(C.MEAN), "std": list(C.STD)},
            "grey_input": "replicate the grey channel into R, G and B",
            "canonical_camera": {"fx": C.FC, "fy": C.FC, "cx": C.CXC, "cy": C.CYC},
            "resampling": {
                "description": "every source camera (fx, fy, cx, cy, undistorted) is mapped to the canonical "
                               "camera by u' = (FC/fx)(u - cx) + CXC, v' = (FC/fy)(v - cy) + CYC "
                               "(pixel centres at integers)",
                "steps": [
                    "sx = FC/fx, sy = FC/fy",
                    "tmp = cv::resize(src, Size(), sx, sy, INTER_AREA)",
                    "tx = 0.5 - 0.5*sx - sx*cx + CXC, ty = 0.5 - 0.5*sy - sy*cy + CYC",
                    "dst = cv::warpAffine(tmp, [[1,0,tx],[0,1,ty]], Size(W,H), INTER_LINEAR, BORDER_CONSTANT, 0)",
                    "canonical pixels whose source position (u - CXC)*fx/FC + cx, (v - CYC)*fy/FC + cy lies "
                    "outside [0, width-1] x [0, height-1] are set to 0 (black) before normalisation",
                ],
            },
        },
        "inputs": {
            "image": [1, 3, C.HEIGHT, C.WIDTH],
            "prev_f1": [1, ENC_CH[0], C.HEIGHT // 2, C.WIDTH // 2],
            "prev_f2": [1, ENC_CH[1], C.HEIGHT // 4, C.WIDTH // 4],
            "prev_f3": [1, ENC_CH[2], C.HEIGHT // 8, C.WIDTH // 8],
            "h": [1, C.HIDDEN], "c": [1, C.HIDDEN],
        },
        "outputs": {
            "pose6": {"shape": [1, 6], "meaning": "T_prev_cur: [tx, ty, tz] metres, [rx, ry, rz] axis-angle radians "
                      "(R = Rodrigues(r)); X_prev = R X_cur + t; T_world_cur = T_world_prev * T_prev_cur; "
                      "camera frame x right, y down, z forward"},
            "depth": {"shape": [1, 1, C.HEIGHT, C.WIDTH], "meaning": "metric depth (metres, z) of the current "
                      f"frame in the canonical camera, range [{C.DMIN}, {C.DMAX}]; map to source pixels with the "
                      "inverse of the resampling affine"},
            "h_out": {"shape": [1, C.HIDDEN], "meaning": "LSTM hidden state: feed back as h"},
            "c_out": {"shape": [1, C.HIDDEN], "meaning": "LSTM cell state: feed back as c"},
            "f1": {"shape": [1, ENC_CH[0], C.HEIGHT // 2, C.WIDTH // 2], "meaning": "feed back as prev_f1"},
            "f2": {"shape": [1, ENC_CH[1], C.HEIGHT // 4, C.WIDTH // 4], "meaning": "feed back as prev_f2"},
            "f3": {"shape": [1, ENC_CH[2], C.HEIGHT // 8, C.WIDTH // 8], "meaning": "feed back as prev_f3"},
        },
        "state": [{"input": "prev_f1", "output": "f1"}, {"input": "prev_f2", "output": "f2"},
                  {"input": "prev_f3", "output": "f3"}, {"input": "h", "output": "h_out", "first_frame": "discard"},
                  {"input": "c", "output": "c_out", "first_frame": "discard"}],
        "protocol": [
            "first frame of a session: run with prev_f1 = prev_f2 = prev_f3 = 0 and h = c = 0; ignore pose6, "
            "h_out, c_out; keep f1, f2, f3 (depth is valid); h and c stay 0",
            "every later frame: run with the previous step's f1, f2, f3 as prev_f1, prev_f2, prev_f3 and its "
            "h_out, c_out as h, c; pose6 is the motion since the previous frame",
            "the network was trained on 15-30 Hz sequences with frame strides 1-3 (up to ~12 cm and ~10 deg "
            "per step); reset the state (as for a first frame) after a tracking loss or a gap",
        ],
    }
    if extra:
        d.update(extra)
    return d


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("ckpt")
    ap.add_argument("--out", required=True, help=".onnx path; the JSON sidecar goes next to it")
    ap.add_argument("--extra-json", help="JSON object merged into the sidecar (training facts, results)")
    a = ap.parse_args(argv)
    torch.set_num_threads(1)
    ck = torch.load(a.ckpt, map_location="cpu")
    net = VONet()
    net.load_state_dict(ck["model"])
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    export_onnx(net, a.out)
    diff = check_onnx(net, a.out, steps=6)
    ms, p90 = time_cv(a.out)
    extra = {"training": {"step": ck.get("step"), "config": {k: v for k, v in ck.get("config", {}).items()
                                                             if k not in ("out",)}},
             "check": {"max_abs_diff_vs_torch_6_steps": diff, "cv_dnn_ms_1_thread_median": round(ms, 2),
                       "cv_dnn_ms_1_thread_p90": round(p90, 2), "opencv": cv2.__version__}}
    if a.extra_json:
        with open(a.extra_json) as f:
            extra.update(json.load(f))
    js = sidecar(a.out, extra)
    jpath = os.path.splitext(a.out)[0] + ".json"
    with open(jpath, "w") as f:
        json.dump(js, f, indent=1)
    size = os.path.getsize(a.out)
    print(f"export: {a.out} ({size / 1e6:.2f} MB, sha256 {js['sha256']}), {jpath}; "
          f"max |cv2.dnn - torch| over 6 steps {diff:.2e}; cv2.dnn {ms:.2f} ms/step (1 thread, median)")
    if diff > 1e-4:
        print("export: ERROR: cv2.dnn output differs from PyTorch", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
