"""Plain results of the client's calls (no protobuf in the API)."""
from dataclasses import dataclass, field
from typing import List, Optional, Tuple

import numpy as np


@dataclass(frozen=True)
class Camera:
    """Pinhole calibration of the colour camera; distortion is OpenCV's (k1, k2, p1, p2, k3)."""
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    distortion: Tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class MapInfo:
    name: str
    session_count: int
    keyframe_count: int
    created: float  # seconds since the Unix epoch


@dataclass(frozen=True)
class SessionInfo:
    map: str
    name: str
    mode: str  # "RGBD", "MONO", "KNOWN_POSES"
    frame_count: int
    keyframe_count: int
    started: float
    ended: Optional[float]  # None while streaming
    end_reason: str  # "COMPLETED", "CANCELLED", "ERROR", ... ("UNSPECIFIED" while streaming)
    end_message: str
    camera: Camera


@dataclass(frozen=True)
class ObjectInstance:
    """Where a labelled object is: position and full extent along the map axes, in metres."""
    label: str
    map: str
    position: np.ndarray  # (3,)
    extent: np.ndarray  # (3,)
    confidence: float
    observations: int
    sessions: List[str] = field(default_factory=list)
    distance: float = 0.0  # near(): metres from the query point


@dataclass(frozen=True)
class ObjectType:
    label: str
    map: str  # "" for a global type
    views: int
    features: int
    colour: Tuple[int, int, int]


@dataclass(frozen=True)
class Export:
    format: str
    media_type: str
    path: Optional[str]  # where it was written (None: kept in `data`)
    data: Optional[bytes]
    size: int
    sha256: str  # checked against the server's trailer
    layer_origin: np.ndarray  # map coordinates = layer coordinates + layer_origin


@dataclass(frozen=True)
class Started:
    """The first event of an ingest: the session the server created."""
    map: str
    session: str


@dataclass(frozen=True)
class Ack:
    """One frame's pose (T_world_camera as a 4x4) and how durable the session is so far."""
    seq: int
    T_world_camera: np.ndarray
    is_keyframe: bool
    lost: bool
    durable_seq: Optional[int]


@dataclass(frozen=True)
class Progress:
    frames_received: int
    frames_processed: int
    keyframes: int
    durable_seq: Optional[int]
    queue_depth: int


@dataclass(frozen=True)
class Summary:
    """The last event of a completed ingest."""
    map: str
    session: str
    frames: int
    keyframes: int
    durable_seq: Optional[int]
    duration_s: float
    lost_frames: int
    loop_closures: int
