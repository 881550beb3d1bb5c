#!/usr/bin/env python3
"""Generates semmap/v1/*_pb2.py and service_pb2_grpc.py from the repository's proto/.

The stubs are generated code, never edited by hand: run this after changing a .proto file
(tests/test_stubs.py fails while they are out of step). Uses Debian's protoc (protobuf-compiler
3.21) and grpc_python_plugin (protobuf-compiler-grpc), the versions python3-protobuf and
python3-grpcio match.

    python3 client/python/generate_stubs.py [--out DIR]
"""
import argparse
import pathlib
import shutil
import subprocess
import sys

HERE = pathlib.Path(__file__).resolve().parent
PROTO_ROOT = HERE.parent.parent / "proto"
PROTOS = ["semmap/v1/frames.proto", "semmap/v1/map.proto", "semmap/v1/objects.proto",
          "semmap/v1/service.proto"]


def generate(out_dir: pathlib.Path) -> list:
    """Writes the stubs under out_dir/semmap/v1/ and returns their paths."""
    protoc = shutil.which("protoc")
    plugin = shutil.which("grpc_python_plugin")
    if protoc is None or plugin is None:
        raise RuntimeError("generate_stubs: needs protoc and grpc_python_plugin "
                           "(apt install protobuf-compiler protobuf-compiler-grpc)")
    out_dir.mkdir(parents=True, exist_ok=True)
    subprocess.run([protoc, f"-I{PROTO_ROOT}", f"--python_out={out_dir}", *PROTOS],
                   check=True)
    subprocess.run([protoc, f"-I{PROTO_ROOT}", f"--plugin=protoc-gen-grpc_python={plugin}",
                    f"--grpc_python_out={out_dir}", "semmap/v1/service.proto"], check=True)
    return sorted((out_dir / "semmap" / "v1").glob("*_pb2*.py"))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=HERE,
                        help="directory that receives semmap/v1/ (default: this package)")
    args = parser.parse_args()
    for path in generate(args.out):
        print(f"generate_stubs: wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
