"""The Python client against a real semmapd on loopback."""
import hashlib
import itertools
import threading
import time

import cv2
import grpc
import numpy as np
import pytest

import semmap
from conftest import SAMPLE, TEDDY_PHOTO

CAMERA = semmap.Camera(160, 120, 150.0, 150.0, 79.5, 59.5)


def synthetic_frames(count, start_s=100.0, step_m=0.05, pulled=None):
    """KNOWN_POSES frames from numpy: noise colour, a flat wall 2 m away, a path along x."""
    rng = np.random.default_rng(3)
    for i in range(count):
        if pulled is not None:
            pulled.append(i)
        colour = rng.integers(0, 256, size=(120, 160, 3), dtype=np.uint8)
        depth = np.full((120, 160), 2000, dtype=np.uint16)  # millimetres (depth_scale 1000)
        T = np.eye(4)
        T[0, 3] = step_m * i
        yield start_s + i / 30.0, colour, depth, T


def test_health_and_an_empty_server(client):
    assert client.health() == "SERVING"
    assert isinstance(client.maps(), list)


def test_numpy_frames_stream_and_their_trajectory_round_trips(client):
    stream = client.ingest(synthetic_frames(40), map="synthetic", session="numpy",
                           camera=CAMERA)
    events = list(stream)
    assert isinstance(events[0], semmap.Started)
    assert events[0].session == "numpy"
    acks = [e for e in events if isinstance(e, semmap.Ack)]
    assert [a.seq for a in acks] == list(range(40))
    assert isinstance(events[-1], semmap.Summary)
    assert events[-1].frames == 40 and events[-1].durable_seq == 39

    trajectory = client.trajectory("synthetic", "numpy")
    assert trajectory.shape == (40, 8)
    assert np.allclose(trajectory[:, 0], 100.0 + np.arange(40) / 30.0, atol=1e-6)
    assert np.allclose(trajectory[:, 1], 0.05 * np.arange(40), atol=1e-9)
    assert np.allclose(trajectory[:, 2:4], 0, atol=1e-9)
    assert np.allclose(np.abs(trajectory[:, 7]), 1, atol=1e-9)  # identity rotation
    sessions = {s.name: s for s in client.sessions("synthetic")}
    assert sessions["numpy"].mode == "KNOWN_POSES"
    assert sessions["numpy"].frame_count == 40
    assert sessions["numpy"].end_reason == "COMPLETED"
    assert sessions["numpy"].camera == CAMERA


def test_rgbd_dataset_folder_objects_where_and_near(client):
    registered = client.register_object("teddy", [str(TEDDY_PHOTO)])  # global: every map
    assert registered.label == "teddy" and registered.map == ""
    assert registered.views == 1 and registered.features > 0
    assert "teddy" in [o.label for o in client.objects()]
    summary = client.ingest(str(SAMPLE), map="home", session="teddy").run()
    assert summary.frames == 80 and summary.keyframes >= 2
    assert client.sessions("home")[0].mode == "RGBD"

    found = client.where("teddy", map="home")
    assert found, "the teddy was not placed"
    teddy = found[0]
    assert teddy.label == "teddy" and teddy.position.shape == (3,)
    assert 0 < teddy.confidence <= 1
    near = client.near(teddy.position, 0.5, map="home")
    assert [o.label for o in near][:1] == ["teddy"]
    assert near[0].distance < 1e-6
    assert client.near(teddy.position + [50, 0, 0], 0.5, map="home") == []


def test_exports_are_checked_and_written(client, tmp_path):
    path = tmp_path / "map.json"
    export = client.export("synthetic", "json", str(path))
    data = path.read_bytes()
    assert export.size == len(data) > 0
    assert export.sha256 == hashlib.sha256(data).hexdigest()
    assert export.media_type == "application/json"
    tum = client.export("synthetic", "tum", session="numpy")
    assert tum.data.count(b"\n") >= 40
    assert hashlib.sha256(tum.data).hexdigest() == tum.sha256


def test_errors_carry_the_status_code_and_the_servers_message(client):
    with pytest.raises(semmap.SemmapError) as missing:
        client.trajectory("no-such-map", "s")
    assert missing.value.code == grpc.StatusCode.NOT_FOUND
    assert "no-such-map" in missing.value.message
    with pytest.raises(semmap.SemmapError) as bad_radius:
        client.near([0, 0, 0], -1.0, map="synthetic")
    assert bad_radius.value.code == grpc.StatusCode.INVALID_ARGUMENT
    bad_camera = semmap.Camera(160, 120, -1.0, 150.0, 79.5, 59.5)
    with pytest.raises(semmap.SemmapError) as refused:
        client.ingest(synthetic_frames(3), map="synthetic", camera=bad_camera).run()
    assert refused.value.code == grpc.StatusCode.INVALID_ARGUMENT
    with pytest.raises(semmap.SemmapError) as not_a_dataset:
        client.ingest("/nonexistent/dataset")
    assert not_a_dataset.value.code == grpc.StatusCode.NOT_FOUND


def test_a_failing_source_is_reported_and_the_session_does_not_end_complete(client):
    def broken():
        yield from synthetic_frames(5)
        raise OSError("camera unplugged")

    with pytest.raises(semmap.SemmapError) as failed:
        client.ingest(broken(), map="synthetic", session="broken", camera=CAMERA).run()
    assert "camera unplugged" in failed.value.message
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        session = {s.name: s for s in client.sessions("synthetic")}.get("broken")
        if session is not None and session.ended is not None:
            break
        time.sleep(0.1)
    assert session.end_reason == "CANCELLED"


def test_cancel_mid_ingest_keeps_what_was_stored(client):
    def slow():
        for frame in synthetic_frames(1000):
            time.sleep(0.01)
            yield frame

    stream = client.ingest(slow(), map="synthetic", session="cancelled", camera=CAMERA)
    durable = None
    with pytest.raises(semmap.SemmapError) as cancelled:
        for event in stream:
            if isinstance(event, semmap.Ack):
                durable = event.durable_seq if event.durable_seq is not None else durable
                if event.seq == 20:
                    stream.cancel()
    assert cancelled.value.code == grpc.StatusCode.CANCELLED
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        session = {s.name: s for s in client.sessions("synthetic")}.get("cancelled")
        if session is not None and session.ended is not None:
            break
        time.sleep(0.1)
    assert session.end_reason == "CANCELLED"
    assert durable is not None and session.frame_count >= durable + 1
    assert session.frame_count < 1000


def test_the_source_is_read_only_as_fast_as_the_server_takes_it(client):
    # 160 full-size RGBD frames sent raw (1.5 MB each) while the server tracks them: a client
    # without flow control would read them all at once.
    dataset = semmap.open_dataset(str(SAMPLE))
    colour = [cv2.cvtColor(cv2.imread(f.colour_path), cv2.COLOR_BGR2RGB)
              for f in dataset.frames[:40]]
    depth = [cv2.imread(f.depth_path, cv2.IMREAD_UNCHANGED) for f in dataset.frames[:40]]
    pulled = []

    def frames():
        for i in range(160):
            pulled.append(i)
            k = i % 80 if i % 80 < 40 else 79 - i % 80  # there and back
            yield 10.0 + i / 30.0, colour[k], depth[k], None

    ahead = 0
    stream = client.ingest(frames(), map="flow", camera=dataset.camera,
                           depth_scale=dataset.depth_scale)
    for event in stream:
        if isinstance(event, semmap.Ack):
            ahead = max(ahead, len(pulled) - stream.acks)
    assert stream.summary.frames == 160
    assert ahead < 60, f"the client read {ahead} frames ahead of the server's acks"
