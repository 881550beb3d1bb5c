#!/usr/bin/env python3
"""Streams a TUM RGB-D folder into semmapd and prints the session's summary.

    examples/stream_tum.py DIR [--server localhost:50051] [--map default] [--poses FILE]
"""
import argparse
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
import semmap  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dir")
    parser.add_argument("--server", default="localhost:50051")
    parser.add_argument("--map", default="default")
    parser.add_argument("--poses", help="TUM trajectory: a KNOWN_POSES session")
    args = parser.parse_args()
    total = len(semmap.open_dataset(args.dir).frames)
    try:
        with semmap.Client(args.server) as client:
            stream = client.ingest(args.dir, map=args.map, poses=args.poses)
            for event in stream:
                if isinstance(event, semmap.Ack):
                    print(f"\r{stream.acks}/{total} frames, durable up to {event.durable_seq}",
                          end="", file=sys.stderr)
            print(file=sys.stderr)
            s = stream.summary
            print(f"{s.map}/{s.session}: {s.frames} frames, {s.keyframes} keyframes, "
                  f"{s.loop_closures} loop closures in {s.duration_s:.1f} s")
    except semmap.SemmapError as error:
        print(f"stream_tum: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
