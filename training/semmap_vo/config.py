"""Fixed conventions shared by the loader, the model, the exporter and the evaluator.

The network runs on ONE canonical pinhole camera. Every source camera (any size, any focal
length) is resampled to it before the network sees an image, so the network never has to
know the real intrinsics: depth and translation come out metric because the canonical focal
length is fixed. The mapping from a source pixel (u, v) (intrinsics fx, fy, cx, cy) to the
canonical pixel (u', v') is the affine map

    u' = (FC / fx) * (u - cx) + CXC
    v' = (FC / fy) * (v - cy) + CYC

(pixel centres at integer coordinates, OpenCV convention). Canonical pixels that fall outside
the source image are filled with 0 (black, before normalisation) and are invalid for the losses.
The camera frame (x right, y down, z forward) is the same for the source and canonical cameras,
so poses need no conversion, only images do.
"""
import os

# Network input (canonical camera) size and intrinsics.
WIDTH = 128
HEIGHT = 96
FC = 105.0  # canonical focal length in pixels (= 525 px at 640 x 480 scaled by 0.2: HFOV 62.9 deg)
CXC = (WIDTH - 1) / 2.0
CYC = (HEIGHT - 1) / 2.0

# Image normalisation: x = (rgb / 255 - MEAN) / STD, channels in R, G, B order, NCHW.
MEAN = (0.45, 0.45, 0.45)
STD = (0.225, 0.225, 0.225)

# Depth head range (metres): depth = exp(log(DMIN) + sigmoid(z) * (log(DMAX) - log(DMIN))).
DMIN = 0.1
DMAX = 20.0

# Recurrent state.
HIDDEN = 256

# Where generated data, caches and training runs go (outside the repository).
CACHE_DIR = os.environ.get("SEMMAP_VO_CACHE", os.path.join(os.path.expanduser("~"), ".cache", "semmap", "vo"))
EXTRA_DATA = os.environ.get("SEMMAP_EXTRA_DATA", os.path.join(os.path.expanduser("~"), ".cache", "semmap", "data"))


def canonical_K():
    """3x3 intrinsics of the canonical (network) camera, as nested lists."""
    return [[FC, 0.0, CXC], [0.0, FC, CYC], [0.0, 0.0, 1.0]]
