"""The exported step model imports in OpenCV DNN (4.6) and matches PyTorch over recurrent steps."""
import os

import cv2
import numpy as np
import pytest
import torch

from semmap_vo import config as C
from semmap_vo.export import check_onnx, cv_forward, export_onnx, load_cv_net, sidecar
from semmap_vo.model import INPUT_NAMES, OUTPUT_NAMES, VONet

SHIPPED = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))),
                       "models", "vo", "semmap_vo.onnx")


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    torch.manual_seed(3)
    net = VONet().eval()
    # perturb biases so outputs are not trivially near constant
    with torch.no_grad():
        for p in net.parameters():
            p.add_(0.02 * torch.randn_like(p))
    path = str(tmp_path_factory.mktemp("onnx") / "vo.onnx")
    export_onnx(net, path)
    return net, path


def test_onnx_matches_torch_over_recurrent_steps(exported):
    net, path = exported
    diff = check_onnx(net, path, steps=5, seed=1)
    assert diff < 1e-4, diff


def test_onnx_io_names_and_shapes(exported):
    _, path = exported
    cvnet = load_cv_net(path)
    inputs = [np.zeros((1, 3, C.HEIGHT, C.WIDTH), np.float32)] + [s.numpy() for s in VONet.zero_state(1)]
    outs = cv_forward(cvnet, inputs)
    shapes = [o.shape for o in outs]
    assert shapes == [(1, 6), (1, 1, C.HEIGHT, C.WIDTH), (1, C.HIDDEN), (1, C.HIDDEN),
                      tuple(inputs[1].shape), tuple(inputs[2].shape), tuple(inputs[3].shape)]
    depth = outs[1]
    assert depth.min() >= C.DMIN * 0.999 and depth.max() <= C.DMAX * 1.001
    js = sidecar(path)
    assert list(js["inputs"]) == INPUT_NAMES and list(js["outputs"]) == OUTPUT_NAMES


def test_features_carry_equals_pair_evaluation(exported):
    """Carrying f2/f3 gives the same pose as evaluating the pair (prev, cur) from scratch."""
    net, _ = exported
    g = torch.Generator().manual_seed(0)
    a, b = torch.randn(2, 1, 3, C.HEIGHT, C.WIDTH, generator=g)
    z = VONet.zero_state(1)
    with torch.no_grad():
        _, _, _, _, f1, f2, f3 = net(a, *z)
        p1 = net(b, f1, f2, f3, z[3], z[4])[0]
        fa = net.encode(a)
        fb = net.encode(b)
        p2 = net.step(fb, fa[0], fa[1], fa[2], z[3], z[4], with_depth=False)[0]
    assert torch.allclose(p1, p2, atol=1e-6)


@pytest.mark.skipif(not os.path.exists(SHIPPED), reason="models/vo/semmap_vo.onnx not present")
def test_shipped_model_loads_and_matches_sidecar():
    import hashlib
    import json
    with open(os.path.splitext(SHIPPED)[0] + ".json") as f:
        js = json.load(f)
    assert hashlib.sha256(open(SHIPPED, "rb").read()).hexdigest() == js["sha256"]
    assert os.path.getsize(SHIPPED) <= 20e6
    assert js["input"]["width"] == C.WIDTH and js["input"]["height"] == C.HEIGHT
    cvnet = load_cv_net(SHIPPED)
    outs = cv_forward(cvnet, [np.zeros((1, 3, C.HEIGHT, C.WIDTH), np.float32)] +
                      [s.numpy() for s in VONet.zero_state(1)])
    assert all(np.isfinite(o).all() for o in outs)
