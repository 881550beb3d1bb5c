"""Client: the semmapd API in Python, the same shape as the C++ MapQueryInterface plus ingest."""
import hashlib
import itertools
import os
import threading
from typing import Any, Iterable, Iterator, List, Optional, Sequence, Tuple, Union

import grpc
import numpy as np

from .datasets import Dataset, PoseLookup, open_dataset, read_tum_trajectory
from .errors import SemmapError
from .poses import pose_matrix, quaternion_xyzw
from .types import (Ack, Camera, Export, MapInfo, ObjectInstance, ObjectType, Progress,
                    SessionInfo, Started, Summary)
from .v1 import frames_pb2, map_pb2, objects_pb2, service_pb2, service_pb2_grpc

MODES = {"RGBD": map_pb2.SESSION_MODE_RGBD, "MONO": map_pb2.SESSION_MODE_MONO,
         "KNOWN_POSES": map_pb2.SESSION_MODE_KNOWN_POSES}
_HEALTH = ["UNKNOWN", "SERVING", "NOT_SERVING", "SERVICE_UNKNOWN"]

# A frame of an iterator source: (stamp in seconds, colour H x W x 3 uint8 (or H x W grey),
# depth H x W uint16 (raw units, see depth_scale) or float32 metres or None, T_world_camera
# 4x4 or None).
FrameTuple = Tuple[float, np.ndarray, Optional[np.ndarray], Optional[np.ndarray]]


def _read(path: Optional[str]) -> Optional[bytes]:
    if path is None:
        return None
    with open(path, "rb") as f:
        return f.read()


def _seconds(timestamp) -> float:
    return timestamp.seconds + timestamp.nanos * 1e-9


def _vector(v) -> np.ndarray:
    return np.array([v.x, v.y, v.z])


def _matrix(pose) -> np.ndarray:
    o = pose.orientation
    return pose_matrix(_vector(pose.position), (o.x, o.y, o.z, o.w))


def _to_pose(T: np.ndarray) -> frames_pb2.Pose:
    T = np.asarray(T, dtype=np.float64)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT,
                          "a pose must be a finite 4x4 matrix (T_world_camera)")
    q = quaternion_xyzw(T[:3, :3])
    pose = frames_pb2.Pose()
    pose.position.x, pose.position.y, pose.position.z = (float(v) for v in T[:3, 3])
    o = pose.orientation
    o.x, o.y, o.z, o.w = (float(v) for v in q)
    return pose


def _camera_proto(camera: Camera) -> frames_pb2.CameraCalibration:
    proto = frames_pb2.CameraCalibration(width=camera.width, height=camera.height)
    proto.K.extend([camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1])
    if any(camera.distortion):
        proto.distortion_model = "plumb_bob"
        proto.D.extend(camera.distortion)
    return proto


def _camera(proto: frames_pb2.CameraCalibration) -> Camera:
    K = list(proto.K) if len(proto.K) == 9 else [0.0] * 9
    D = tuple(proto.D) + (0.0,) * (5 - len(proto.D))
    return Camera(proto.width, proto.height, K[0], K[4], K[2], K[5], D[:5])


def _instance(o: objects_pb2.ObjectInstanceInfo) -> ObjectInstance:
    return ObjectInstance(o.label, o.map, _vector(o.position), _vector(o.extent), o.confidence,
                          o.observations, list(o.sessions), o.distance)


def _object_type(o: objects_pb2.ObjectTypeInfo) -> ObjectType:
    return ObjectType(o.label, o.map, o.views, o.features, (o.colour.r, o.colour.g, o.colour.b))


def _raw_image(array: np.ndarray, colour_order: str) -> frames_pb2.Image:
    array = np.ascontiguousarray(array)
    image = frames_pb2.Image()
    raw = image.raw
    raw.height, raw.width = array.shape[:2]
    if array.dtype == np.uint8 and array.ndim == 2:
        raw.encoding = "mono8"
    elif array.dtype == np.uint8 and array.ndim == 3 and array.shape[2] == 3:
        raw.encoding = "rgb8" if colour_order == "rgb" else "bgr8"
    elif array.dtype == np.uint16 and array.ndim == 2:
        raw.encoding = "16UC1"
    elif array.dtype == np.float32 and array.ndim == 2:
        raw.encoding = "32FC1"
    else:
        raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT,
                          f"cannot send a {array.dtype} image of shape {array.shape}: colour is "
                          "H x W x 3 or H x W uint8, depth H x W uint16 or float32")
    raw.step = array.strides[0]
    raw.data = array.tobytes()
    return image


def _compressed(data: bytes) -> frames_pb2.Image:
    kind = "png" if data[:8] == b"\x89PNG\r\n\x1a\n" else "jpeg" if data[:2] == b"\xff\xd8" else ""
    if not kind:
        raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT, "an image file is neither PNG nor JPEG")
    image = frames_pb2.Image()
    image.compressed.format = kind
    image.compressed.data = data
    return image


class IngestStream:
    """A running ingest. Iterate it for its events (Started, then Ack / Progress per frame, then
    Summary); the source is read only as fast as the server takes frames (gRPC flow control).
    `cancel()` ends it from any thread: the server keeps what it stored."""

    def __init__(self, call_factory, requests: Iterator[service_pb2.IngestRequest]):
        self._error: Optional[BaseException] = None
        self._lock = threading.Lock()
        self.started: Optional[Started] = None
        self.summary: Optional[Summary] = None
        self.acks = 0
        self._call_set = threading.Event()
        self._call = call_factory(self._guard(requests))
        self._call_set.set()

    def _guard(self, requests):
        # gRPC swallows an exception raised by a request iterator; keep it and cancel instead,
        # so the caller sees what went wrong and the session is not ended as complete.
        try:
            yield from requests
        except BaseException as error:  # noqa: BLE001 (re-raised to the caller)
            with self._lock:
                self._error = error
            self._call_set.wait()  # gRPC may read the first request before the call returns
            self._call.cancel()

    def cancel(self) -> None:
        self._call.cancel()

    def __iter__(self):
        try:
            for response in self._call:
                kind = response.WhichOneof("msg")
                if kind == "started":
                    self.started = Started(response.started.map, response.started.session)
                    yield self.started
                elif kind == "ack":
                    a = response.ack
                    self.acks += 1
                    yield Ack(a.seq, _matrix(a.T_world_camera), a.is_keyframe, a.lost,
                              a.durable_seq if a.HasField("durable_seq") else None)
                elif kind == "progress":
                    p = response.progress
                    yield Progress(p.frames_received, p.frames_processed, p.keyframes,
                                   p.durable_seq if p.HasField("durable_seq") else None,
                                   p.queue_depth)
                elif kind == "summary":
                    s = response.summary
                    self.summary = Summary(s.map, s.session, s.frames, s.keyframes,
                                           s.durable_seq if s.HasField("durable_seq") else None,
                                           s.duration_s, s.lost_frames, s.loop_closures)
                    yield self.summary
        except grpc.RpcError as error:
            with self._lock:
                source_error = self._error
            if source_error is not None:
                if isinstance(source_error, SemmapError):
                    raise source_error from None
                raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT,
                                  f"reading the source failed: {source_error!r}") from None
            raise SemmapError.from_rpc_error(error) from None

    def run(self) -> Summary:
        """Consumes every event and returns the summary."""
        for _ in self:
            pass
        if self.summary is None:
            raise SemmapError(grpc.StatusCode.UNKNOWN, "the stream ended without a summary")
        return self.summary


class Client:
    """A connection to semmapd.

    `tls_ca`: PEM file of the CA that signed the server's certificate (TLS); `tls_cert` and
    `tls_key`: this client's certificate for mutual TLS. `token`: bearer token (default
    $SEMMAP_TOKEN). `timeout`: seconds per call (ingest: none unless given). Every failure
    raises SemmapError with the gRPC status code and the server's message.
    """

    def __init__(self, address: str = "localhost:50051", *, tls_ca: Optional[str] = None,
                 tls_cert: Optional[str] = None, tls_key: Optional[str] = None,
                 token: Optional[str] = None, timeout: float = 30.0,
                 max_message_mb: int = 64):
        if (tls_cert is None) != (tls_key is None):
            raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT,
                              "tls_cert and tls_key go together (mutual TLS)")
        token = token if token is not None else os.environ.get("SEMMAP_TOKEN")
        options = [("grpc.max_send_message_length", max_message_mb << 20),
                   ("grpc.max_receive_message_length", max_message_mb << 20)]
        if tls_ca is not None or tls_cert is not None:
            credentials = grpc.ssl_channel_credentials(_read(tls_ca), _read(tls_key),
                                                       _read(tls_cert))
            self._channel = grpc.secure_channel(address, credentials, options)
        else:
            self._channel = grpc.insecure_channel(address, options)
        self._metadata = (("authorization", f"Bearer {token.strip()}"),) if token else ()
        self._stub = service_pb2_grpc.MapServiceStub(self._channel)
        self._health = self._channel.unary_unary(
            "/grpc.health.v1.Health/Check", request_serializer=lambda b: b,
            response_deserializer=lambda b: b)
        self.address = address
        self.timeout = timeout

    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _unary(self, method, request, timeout: Optional[float] = None):
        try:
            return method(request, timeout=timeout or self.timeout, metadata=self._metadata)
        except grpc.RpcError as error:
            raise SemmapError.from_rpc_error(error) from None

    def _stream(self, method, request, timeout: Optional[float] = None):
        try:
            yield from method(request, timeout=timeout or self.timeout, metadata=self._metadata)
        except grpc.RpcError as error:
            raise SemmapError.from_rpc_error(error) from None

    # ---- Health and listings ----

    def health(self) -> str:
        """"SERVING", or "NOT_SERVING" while semmapd shuts down (no token needed)."""
        try:
            answer = self._health(b"", timeout=self.timeout)
        except grpc.RpcError as error:
            raise SemmapError.from_rpc_error(error) from None
        # HealthCheckResponse { ServingStatus status = 1; }: b"" or b"\x08" + one varint byte.
        status = answer[1] if len(answer) >= 2 and answer[0] == 0x08 else 0
        return _HEALTH[status] if status < len(_HEALTH) else f"STATUS_{status}"

    def maps(self) -> List[MapInfo]:
        answer = self._unary(self._stub.ListMaps, service_pb2.ListMapsRequest())
        return [MapInfo(m.name, m.session_count, m.keyframe_count, _seconds(m.created))
                for m in answer.maps]

    def sessions(self, map: str = "") -> List[SessionInfo]:
        """The sessions of `map` (every map when empty)."""
        answer = self._unary(self._stub.ListSessions, service_pb2.ListSessionsRequest(map=map))
        result = []
        for s in answer.sessions:
            result.append(SessionInfo(
                s.map, s.name, map_pb2.SessionMode.Name(s.mode).replace("SESSION_MODE_", ""),
                s.frame_count, s.keyframe_count, _seconds(s.started),
                _seconds(s.ended) if s.HasField("ended") else None,
                map_pb2.SessionEndReason.Name(s.end_reason).replace("SESSION_END_REASON_", ""),
                s.end_message, _camera(s.camera)))
        return result

    def trajectory(self, map: str, session: str, keyframes_only: bool = False) -> np.ndarray:
        """Every frame's T_world_camera (or only keyframes') as an N x 8 array of rows
        (stamp seconds, tx, ty, tz, qx, qy, qz, qw): the TUM trajectory format."""
        rows = []
        request = service_pb2.GetTrajectoryRequest(map=map, session=session,
                                                   keyframes_only=keyframes_only)
        for chunk in self._stream(self._stub.GetTrajectory, request):
            for p in chunk.poses:
                position, o = p.T_world_camera.position, p.T_world_camera.orientation
                rows.append((_seconds(p.timestamp), position.x, position.y, position.z,
                             o.x, o.y, o.z, o.w))
        return np.array(rows, dtype=np.float64).reshape(-1, 8)

    # ---- Objects ----

    def where(self, label: str, map: Optional[str] = None) -> List[ObjectInstance]:
        """Instances of `label` (every label when empty) in `map` (every map when None)."""
        request = objects_pb2.FindObjectsRequest(label=label, map=map or "")
        return [_instance(o) for o in self._unary(self._stub.FindObjects, request).objects]

    def near(self, xyz: Sequence[float], radius: float, label: Optional[str] = None,
             map: Optional[str] = None) -> List[ObjectInstance]:
        """Objects within `radius` metres of the map point `xyz`, nearest first."""
        x, y, z = (float(v) for v in xyz)
        request = objects_pb2.ObjectsNearRequest(map=map or "", radius=float(radius),
                                                 label=label or "")
        request.point.x, request.point.y, request.point.z = x, y, z
        return [_instance(o) for o in self._unary(self._stub.ObjectsNear, request).objects]

    def objects(self, map: Optional[str] = None) -> List[ObjectType]:
        """Registered object types: every one, or the global ones and `map`'s."""
        request = objects_pb2.ListObjectsRequest(map=map or "")
        return [_object_type(o) for o in self._unary(self._stub.ListObjects, request).objects]

    def register_object(self, label: str, photos: Iterable[Union[str, bytes, np.ndarray]],
                        map: Optional[str] = None,
                        colour: Optional[Tuple[int, int, int]] = None) -> ObjectType:
        """Registers an object type from photos: PNG / JPEG file paths or bytes, or BGR uint8
        arrays (encoded as PNG). Recognised in keyframes from then on."""
        request = objects_pb2.RegisterObjectRequest(label=label, map=map or "")
        for photo in photos:
            if isinstance(photo, np.ndarray):
                import cv2

                ok, encoded = cv2.imencode(".png", photo)
                if not ok:
                    raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT,
                                      "a photo array could not be encoded as PNG")
                data = encoded.tobytes()
            elif isinstance(photo, (bytes, bytearray)):
                data = bytes(photo)
            else:
                data = _read(str(photo))
            request.photos.append(_compressed(data).compressed)
        if colour is not None:
            request.colour.r, request.colour.g, request.colour.b = (int(c) for c in colour)
        return _object_type(self._unary(self._stub.RegisterObject, request).object)

    def remove_object(self, label: str, map: Optional[str] = None) -> None:
        self._unary(self._stub.RemoveObject,
                    objects_pb2.RemoveObjectRequest(label=label, map=map or ""))

    # ---- Exports and administration ----

    def export(self, map: str, format: str, path: Optional[str] = None, *, session: str = "",
               voxel: float = 0.0, ascii: bool = False, view: str = "", width: int = 0,
               timeout: Optional[float] = None) -> Export:
        """A map product ("json", "tum", "ot", "bt", "ply", "pcd", "png"), its SHA-256 checked
        against the server's. Written to `path` (replaced only once complete and checked) or,
        with path None, returned in `.data`."""
        request = service_pb2.ExportMapRequest(map=map, format=format, session=session,
                                               ascii=ascii, voxel=voxel, view=view, width=width)
        header, trailer, digest, parts = None, None, hashlib.sha256(), []
        for message in self._stream(self._stub.ExportMap, request, timeout):
            kind = message.WhichOneof("msg")
            if kind == "header":
                header = message.header
            elif kind == "chunk":
                digest.update(message.chunk)
                parts.append(message.chunk)
            elif kind == "trailer":
                trailer = message.trailer
        data = b"".join(parts)
        if header is None or trailer is None:
            raise SemmapError(grpc.StatusCode.DATA_LOSS, "the export ended without its header "
                              "or trailer")
        if digest.hexdigest() != trailer.sha256 or len(data) != trailer.total_bytes:
            raise SemmapError(grpc.StatusCode.DATA_LOSS,
                              f"the export's SHA-256 {digest.hexdigest()} ({len(data)} bytes) "
                              f"differs from the server's {trailer.sha256} "
                              f"({trailer.total_bytes} bytes)")
        if path is not None:
            partial = f"{path}.partial"
            with open(partial, "wb") as f:
                f.write(data)
            os.replace(partial, path)
        return Export(header.format, header.media_type, path, None if path else data, len(data),
                      trailer.sha256, _vector(header.layer_origin))

    def remove_session(self, map: str, session: str) -> Tuple[int, int]:
        """Removes a session; returns (frames, keyframes) removed with it (admin token)."""
        answer = self._unary(self._stub.RemoveSession,
                             service_pb2.RemoveSessionRequest(map=map, session=session))
        return answer.frames, answer.keyframes

    def remove_map(self, map: str) -> Tuple[int, int, int]:
        """Removes a map; returns (sessions, frames, keyframes) removed (admin token)."""
        answer = self._unary(self._stub.RemoveMap, service_pb2.RemoveMapRequest(map=map))
        return answer.sessions, answer.frames, answer.keyframes

    # ---- Ingest ----

    def ingest(self, source: Union[str, os.PathLike, Iterable[FrameTuple]], map: str = "default",
               session: Optional[str] = None, mode: Optional[str] = None,
               poses: Union[str, np.ndarray, None] = None, *, camera: Optional[Camera] = None,
               depth_scale: float = 1000.0, colour_order: str = "rgb",
               keyframe_min_motion: float = 0.0, timeout: Optional[float] = None
               ) -> IngestStream:
        """Streams frames into `map` as a new session; iterate the result for its events.

        `source`: a dataset folder (TUM RGB-D, KITTI or an image folder with camera.yaml, as
        `semmap ingest` reads them; images sent as their files) or an iterable of FrameTuple
        (stamp_s, colour, depth or None, T_world_camera or None), sent raw; then `camera` is
        required, `colour_order` says whether 3-channel colour is "rgb" or "bgr", and uint16
        depth is in units of 1/depth_scale metres (float32 depth is metres).
        `mode`: "RGBD", "MONO" or "KNOWN_POSES"; default: KNOWN_POSES when poses come with the
        frames, RGBD when depth does, else MONO. `poses`: for a dataset folder, a TUM
        trajectory file (relative to the folder or absolute) or an N x 8 array of its rows:
        frames without a pose within 20 ms are skipped.
        """
        if colour_order not in ("rgb", "bgr"):
            raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT, "colour_order is 'rgb' or 'bgr'")
        if mode is not None and mode not in MODES:
            raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT,
                              f"mode is one of {sorted(MODES)}, not {mode!r}")
        if isinstance(source, (str, os.PathLike)):
            dataset = open_dataset(os.fspath(source))
            lookup = self._pose_lookup(dataset, poses)
            frames = self._dataset_frames(dataset, lookup)
            camera = dataset.camera
            if mode is None:
                mode = "KNOWN_POSES" if lookup else "RGBD" if dataset.depth_scale > 0 else "MONO"
        else:
            if camera is None:
                raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT,
                                  "an iterator source needs camera=Camera(...)")
            iterator = iter(source)
            first = next(iterator, None)
            if first is None:
                raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT, "the source has no frames")
            if mode is None:
                mode = ("KNOWN_POSES" if first[3] is not None else
                        "RGBD" if first[2] is not None else "MONO")
            frames = self._array_frames(itertools.chain([first], iterator), depth_scale,
                                        colour_order)
        start = service_pb2.IngestStart(map=map, session=session or "", mode=MODES[mode])
        start.camera.CopyFrom(_camera_proto(camera))
        start.keyframes.min_motion = keyframe_min_motion

        def requests():
            yield service_pb2.IngestRequest(start=start)
            for frame in frames:
                yield service_pb2.IngestRequest(frame=frame)
            yield service_pb2.IngestRequest(end=service_pb2.IngestEnd())

        return IngestStream(
            lambda guarded: self._stub.Ingest(guarded, timeout=timeout, metadata=self._metadata),
            requests())

    @staticmethod
    def _pose_lookup(dataset: Dataset, poses) -> Optional[PoseLookup]:
        if poses is None:
            return None
        if isinstance(poses, np.ndarray):
            trajectory = np.asarray(poses, dtype=np.float64).reshape(-1, 8)
            return PoseLookup(trajectory[np.argsort(trajectory[:, 0], kind="stable")])
        path = os.fspath(poses)
        if not os.path.isabs(path) and not os.path.exists(path):
            path = os.path.join(dataset.dir, path)
        return PoseLookup(read_tum_trajectory(path))

    @staticmethod
    def _dataset_frames(dataset: Dataset, lookup: Optional[PoseLookup]):
        seq = 0
        for frame in dataset.frames:
            message = service_pb2.Frame(seq=seq)
            if lookup is not None:
                T = lookup.at(frame.stamp_s)
                if T is None:
                    continue
                message.pose_prior.CopyFrom(_to_pose(T))
            _stamp(message, frame.stamp_s)
            message.colour.CopyFrom(_compressed(_read(frame.colour_path)))
            if frame.depth_path is not None and dataset.depth_scale > 0:
                message.depth.image.CopyFrom(_compressed(_read(frame.depth_path)))
                message.depth.depth_scale = dataset.depth_scale
            seq += 1
            yield message

    @staticmethod
    def _array_frames(frames: Iterable[Any], depth_scale: float, colour_order: str):
        for seq, item in enumerate(frames):
            if len(item) != 4:
                raise SemmapError(grpc.StatusCode.INVALID_ARGUMENT,
                                  f"frame {seq}: expected (stamp_s, colour, depth, pose)")
            stamp, colour, depth, pose = item
            message = service_pb2.Frame(seq=seq)
            _stamp(message, float(stamp))
            message.colour.CopyFrom(_raw_image(colour, colour_order))
            if depth is not None:
                message.depth.image.CopyFrom(_raw_image(depth, colour_order))
                message.depth.depth_scale = depth_scale if depth.dtype == np.uint16 else 1.0
            if pose is not None:
                message.pose_prior.CopyFrom(_to_pose(pose))
            yield message


def _stamp(message: service_pb2.Frame, stamp_s: float) -> None:
    seconds = int(np.floor(stamp_s))
    message.timestamp.seconds = seconds
    message.timestamp.nanos = min(int(round((stamp_s - seconds) * 1e9)), 999_999_999)
