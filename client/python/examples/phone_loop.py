#!/usr/bin/env python3
"""A phone-style app: sends camera frames (here read from a TUM folder, as a phone would
capture them) while asking "where is the X?" every second, as an assistive app would.

    examples/phone_loop.py DIR LABEL [--server localhost:50051] [--map home] [--fps 30]
"""
import argparse
import pathlib
import sys
import threading
import time

import cv2

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
import semmap  # noqa: E402


def camera_frames(dataset, fps):
    """What a phone's capture loop yields: (stamp, RGB array, depth array or None, None)."""
    start = time.monotonic()
    for i, frame in enumerate(dataset.frames):
        time.sleep(max(0.0, start + i / fps - time.monotonic()))  # the camera's own pace
        colour = cv2.cvtColor(cv2.imread(frame.colour_path), cv2.COLOR_BGR2RGB)
        depth = (cv2.imread(frame.depth_path, cv2.IMREAD_UNCHANGED)
                 if frame.depth_path else None)
        yield time.time(), colour, depth, None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir")
    parser.add_argument("label")
    parser.add_argument("--server", default="localhost:50051")
    parser.add_argument("--map", default="home")
    parser.add_argument("--fps", type=float, default=30)
    args = parser.parse_args()
    dataset = semmap.open_dataset(args.dir)
    done = threading.Event()

    with semmap.Client(args.server) as client:
        def ask():
            while not done.wait(1.0):
                try:
                    found = client.where(args.label, map=args.map)
                except semmap.SemmapError as error:  # the map may not exist yet
                    print(f"where {args.label}: {error.code.name}")
                    continue
                for o in found:
                    x, y, z = o.position
                    print(f"the {o.label} is at ({x:.2f}, {y:.2f}, {z:.2f}) m, "
                          f"confidence {o.confidence:.2f}")
                if not found:
                    print(f"no {args.label} seen yet")

        asker = threading.Thread(target=ask)
        asker.start()
        try:
            summary = client.ingest(camera_frames(dataset, args.fps), map=args.map,
                                    camera=dataset.camera, depth_scale=dataset.depth_scale).run()
            print(f"streamed {summary.frames} frames, {summary.keyframes} keyframes")
        except semmap.SemmapError as error:
            print(f"phone_loop: {error}", file=sys.stderr)
            return 1
        finally:
            done.set()
            asker.join()
    return 0


if __name__ == "__main__":
    sys.exit(main())
