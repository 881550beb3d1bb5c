"""The recurrent convolutional VO network (the seed's RCNN), small enough for 1 CPU thread.

One step of the network sees the current canonical frame (see config.py) and the previous
frame's encoder features (carried as recurrent state, so each frame is encoded once), plus the
LSTM state (h, c). It returns

    pose6  (N, 6)   T_prev_cur: [tx, ty, tz] metres, [rx, ry, rz] axis-angle radians.
                    X_prev = R(r) X_cur + t, i.e. the current camera's pose in the previous
                    camera's frame; T_world_cur = T_world_prev * T_prev_cur.
    depth  (N, 1, H, W)  metric depth (metres, z along the optical axis) of the current frame
                    in the canonical camera.
    h, c   (N, HIDDEN)   new LSTM state.
    f2, f3  current frame's encoder features, to feed as prev_f2, prev_f3 at the next step.

The LSTM is an explicit cell (Linear + sigmoid/tanh, state as plain inputs/outputs) because
OpenCV 4.6's ONNX importer cannot import torch's stacked nn.LSTM.
"""
import math

import torch
import torch.nn as nn
import torch.nn.functional as F

from . import config as C

ENC_CH = (16, 32, 64, 96, 128)  # f1..f5 channels (strides 2, 4, 8, 16, 32)
POSE_SCALE = 0.01  # pose head output scale: small initial motions


def conv(cin, cout, k=3, s=1):
    return nn.Sequential(nn.Conv2d(cin, cout, k, s, k // 2), nn.LeakyReLU(0.1))


def convbn(cin, cout, k=3, s=1):
    """Conv + BatchNorm + LeakyReLU (the pose branch: BN keeps its activations from collapsing to a
    constant early in training; in the exported graph BN is folded into the conv)."""
    return nn.Sequential(nn.Conv2d(cin, cout, k, s, k // 2, bias=False), nn.BatchNorm2d(cout), nn.LeakyReLU(0.1))


class Encoder(nn.Module):
    def __init__(self):
        super().__init__()
        c1, c2, c3, c4, c5 = ENC_CH
        self.l1 = conv(3, c1, 3, 2)
        self.l2 = nn.Sequential(conv(c1, c2, 3, 2), conv(c2, c2))
        self.l3 = nn.Sequential(conv(c2, c3, 3, 2), conv(c3, c3))
        self.l4 = conv(c3, c4, 3, 2)
        self.l5 = conv(c4, c5, 3, 2)

    def forward(self, x):
        f1 = self.l1(x)
        f2 = self.l2(f1)
        f3 = self.l3(f2)
        f4 = self.l4(f3)
        f5 = self.l5(f4)
        return f1, f2, f3, f4, f5


class DepthDecoder(nn.Module):
    """U-Net decoder from the current frame's features; log-depth in [DMIN, DMAX]."""

    def __init__(self):
        super().__init__()
        c1, c2, c3, c4, c5 = ENC_CH
        self.u4 = conv(c5 + c4, 64)
        self.u3 = conv(64 + c3, 48)
        self.u2 = conv(48 + c2, 32)
        self.u1 = conv(32 + c1, 16)
        self.out = nn.Conv2d(16, 1, 3, 1, 1)
        self.log_min = math.log(C.DMIN)
        self.log_range = math.log(C.DMAX) - math.log(C.DMIN)

    @staticmethod
    def up(x):
        return F.interpolate(x, scale_factor=2.0, mode="nearest")

    def forward(self, f1, f2, f3, f4, f5):
        x = self.u4(torch.cat([self.up(f5), f4], 1))
        x = self.u3(torch.cat([self.up(x), f3], 1))
        x = self.u2(torch.cat([self.up(x), f2], 1))
        x = self.u1(torch.cat([self.up(x), f1], 1))
        z = self.out(x)  # (N,1,H/2,W/2)
        z = F.interpolate(z, scale_factor=2.0, mode="bilinear", align_corners=False)
        return torch.exp(torch.sigmoid(z) * self.log_range + self.log_min)


class LSTMCellExplicit(nn.Module):
    """LSTM cell as plain Linear layers: gates i, f, g, o (torch's order)."""

    def __init__(self, nin, nh):
        super().__init__()
        self.nh = nh
        self.wx = nn.Linear(nin, 4 * nh)
        self.wh = nn.Linear(nh, 4 * nh, bias=False)
        with torch.no_grad():  # forget-gate bias 1: remember by default
            self.wx.bias.zero_()
            self.wx.bias[nh:2 * nh].fill_(1.0)

    def forward(self, x, h, c):
        g = self.wx(x) + self.wh(h)
        nh = self.nh
        i = torch.sigmoid(g[:, 0:nh])
        f = torch.sigmoid(g[:, nh:2 * nh])
        gg = torch.tanh(g[:, 2 * nh:3 * nh])
        o = torch.sigmoid(g[:, 3 * nh:4 * nh])
        c2 = f * c + i * gg
        h2 = o * torch.tanh(c2)
        return h2, c2


class Correlation(nn.Module):
    """Local cost volume: for each displacement (dx, dy) in [-r, r]^2, the channel mean of
    cur(p) * prev(p + d). Built from Conv, Slice, Mul and Concat so that OpenCV 4.6 DNN imports it
    (its ONNX Pad import fails: zero padding is a fixed depthwise 1x1 conv with padding r)."""

    def __init__(self, channels, radius):
        super().__init__()
        self.r = radius
        n = (2 * radius + 1) ** 2
        self.register_buffer("w", torch.full((n, channels, 1, 1), 1.0 / channels), persistent=False)
        self.register_buffer("pad_w", torch.ones(channels, 1, 1, 1), persistent=False)
        self.channels = channels

    def forward(self, prev, cur):
        r = self.r
        h, w = cur.shape[-2:]
        p = F.conv2d(prev, self.pad_w, padding=r, groups=self.channels)
        prods = [cur * p[:, :, dy:dy + h, dx:dx + w] for dy in range(2 * r + 1) for dx in range(2 * r + 1)]
        return F.leaky_relu(F.conv2d(torch.cat(prods, 1), self.w, groups=len(prods)), 0.1)


class PoseNet(nn.Module):
    """Motion from matching only: local cost volumes between the previous and current frames'
    encoder features at strides 2, 4 and 8 (5x5, 7x7 and 5x5 displacements) -> conv -> flatten ->
    LSTM -> pose6. The branch sees matching scores, not appearance, so it cannot learn motion
    from where the camera is (memorising scenes); it has to read the displacement pattern."""

    def __init__(self):
        super().__init__()
        c1, c2, c3, c4, c5 = ENC_CH
        self.corr1 = Correlation(c1, 2)              # stride 2: +-4 canonical px
        self.corr2 = Correlation(c2, 2)              # stride 4: +-8 canonical px
        self.corr3 = Correlation(c3, 2)              # stride 8: +-16 canonical px
        self.p0 = convbn(25, 32, 3, 2)               # stride 4
        self.p1 = convbn(32 + 25, 64, 3, 2)          # stride 8
        self.p2 = convbn(64 + 25, 128, 3, 2)         # stride 16
        self.p3 = convbn(128, 128, 3, 2)             # stride 32: (3, 4)
        nflat = 128 * (C.HEIGHT // 32) * (C.WIDTH // 32)
        self.fc = nn.Sequential(nn.Linear(nflat, C.HIDDEN), nn.LeakyReLU(0.1))
        self.lstm = LSTMCellExplicit(C.HIDDEN, C.HIDDEN)
        self.head = nn.Linear(2 * C.HIDDEN, 6)

    def reset_parameters(self):
        """LSTM: uniform init (torch's LSTM default), forget-gate bias 1; small pose head."""
        b = 1.0 / math.sqrt(C.HIDDEN)
        with torch.no_grad():
            for lin in (self.lstm.wx, self.lstm.wh):
                lin.weight.uniform_(-b, b)
            self.lstm.wx.bias.uniform_(-1e-3, 1e-3)
            self.lstm.wx.bias[C.HIDDEN:2 * C.HIDDEN] += 1.0
            self.head.weight.mul_(0.1)
            self.head.bias.uniform_(-1e-3, 1e-3)

    def features(self, pf1, pf2, pf3, f1, f2, f3):
        """The non-recurrent part (batched over all pairs of a chunk in training)."""
        x = self.p0(self.corr1(pf1, f1))
        x = self.p1(torch.cat([x, self.corr2(pf2, f2)], 1))
        x = self.p2(torch.cat([x, self.corr3(pf3, f3)], 1))
        x = self.p3(x)
        return self.fc(torch.flatten(x, 1))

    def recur(self, x, h, c):
        h2, c2 = self.lstm(x, h, c)
        pose = self.head(torch.cat([x, h2], 1)) * POSE_SCALE
        return pose, h2, c2

    def forward(self, pf1, pf2, pf3, f1, f2, f3, h, c):
        return self.recur(self.features(pf1, pf2, pf3, f1, f2, f3), h, c)


def init_weights(module):
    """He (Kaiming) initialisation for the LeakyReLU convolutions and linear layers, tiny random
    biases: torch's default init shrinks activations ~3x per layer, which starves the pose branch.
    (Biases are not all zero because torch's ONNX export merges equal initialisers into Identity
    nodes, which OpenCV 4.6 cannot import.)"""
    for m in module.modules():
        if isinstance(m, (nn.Conv2d, nn.Linear)):
            nn.init.kaiming_normal_(m.weight, a=0.1, mode="fan_in", nonlinearity="leaky_relu")
            if m.bias is not None:
                nn.init.uniform_(m.bias, -1e-3, 1e-3)


class VONet(nn.Module):
    def __init__(self):
        super().__init__()
        self.encoder = Encoder()
        self.depth = DepthDecoder()
        self.pose = PoseNet()
        init_weights(self)
        self.pose.reset_parameters()
        with torch.no_grad():  # depth output starts near sigmoid(0): 1.4 m everywhere
            self.depth.out.weight.mul_(0.1)

    def encode(self, img):
        return self.encoder(img)

    def step(self, feats, prev_f1, prev_f2, prev_f3, h, c, with_depth=True):
        """One recurrent step from the current frame's features (output of encode)."""
        f1, f2, f3, f4, f5 = feats
        pose, h2, c2 = self.pose(prev_f1, prev_f2, prev_f3, f1, f2, f3, h, c)
        depth = self.depth(f1, f2, f3, f4, f5) if with_depth else None
        return pose, depth, h2, c2

    def forward(self, img, prev_f1, prev_f2, prev_f3, h, c):
        """The exported step: (image, previous frame's features, h, c) -> (pose6, depth, h, c, f1, f2, f3)."""
        feats = self.encoder(img)
        pose, depth, h2, c2 = self.step(feats, prev_f1, prev_f2, prev_f3, h, c)
        return pose, depth, h2, c2, feats[0], feats[1], feats[2]

    @staticmethod
    def zero_state(n, device="cpu"):
        """Zero carried features and h, c (the inputs after `image`, for the first frame)."""
        z = lambda *s: torch.zeros(*s, device=device)
        return (z(n, ENC_CH[0], C.HEIGHT // 2, C.WIDTH // 2), z(n, ENC_CH[1], C.HEIGHT // 4, C.WIDTH // 4),
                z(n, ENC_CH[2], C.HEIGHT // 8, C.WIDTH // 8), z(n, C.HIDDEN), z(n, C.HIDDEN))


INPUT_NAMES = ["image", "prev_f1", "prev_f2", "prev_f3", "h", "c"]
OUTPUT_NAMES = ["pose6", "depth", "h_out", "c_out", "f1", "f2", "f3"]
