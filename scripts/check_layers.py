#!/usr/bin/env python3
"""The layer rule of the source tree, checked on the includes (CMake checks the links:
cmake/CoreLayers.cmake). Exit 1 with one line per broken include.

  common/            includes nothing of ours but common/
  storage/           common/, storage/
  core/<module>/     common/, storage/, its own module, and core modules of a lower layer:
                     sensor 0 < odometry 1 < slam 2 < mapping 3 | recognition 3 < objects 4
                     < pipeline 5 | query 5; never server/, client/, proto or gRPC
  core/<m>/internal/ only from core/<m>/ itself (and tests and benchmarks)
  server/, client/   may include core/; client/ never includes server/ except serialization

Usage: check_layers.py [ROOT]   (ROOT defaults to the repository this script is in)
"""
import pathlib
import re
import sys

LAYERS = {"sensor": 0, "odometry": 1, "slam": 2, "mapping": 3, "recognition": 3,
          "objects": 4, "pipeline": 5, "query": 5}
INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^">]+)[">]')
FORBIDDEN_IN_CORE = (re.compile(r"^(server|client|proto)/"), re.compile(r"^semmap/v1/"),
                     re.compile(r"^grpc(pp)?/"), re.compile(r"^google/protobuf/"))


def check_file(rel: pathlib.PurePosixPath, text: str) -> list:
    parts = rel.parts
    top = parts[0]
    errors = []
    for number, line in enumerate(text.splitlines(), 1):
        match = INCLUDE.match(line)
        if not match:
            continue
        inc = match.group(1)
        where = f"{rel}:{number}: includes {inc}"
        inc_parts = inc.split("/")
        # internal/ headers stay inside their module (tests and benchmarks may look inside).
        if (len(inc_parts) > 3 and inc_parts[0] == "core" and inc_parts[2] == "internal"
                and top not in ("tests", "bench") and not (top == "core" and parts[1] == inc_parts[1])):
            errors.append(f"{where}: core/{inc_parts[1]}/internal is private to that module")
        if top == "common":
            if inc_parts[0] in ("core", "storage", "server", "client", "tests", "proto"):
                errors.append(f"{where}: common/ is the bottom layer")
        elif top == "storage":
            if inc_parts[0] in ("core", "server", "client", "tests", "proto"):
                errors.append(f"{where}: storage/ depends only on common/")
        elif top == "core" and len(parts) > 2:
            module = parts[1]
            if any(p.match(inc) for p in FORBIDDEN_IN_CORE):
                errors.append(f"{where}: core/ builds without the service, proto and gRPC")
            elif inc_parts[0] == "tests":
                errors.append(f"{where}: core/ does not include test code")
            elif inc_parts[0] == "core" and len(inc_parts) > 2:
                other = inc_parts[1]
                if other not in LAYERS:
                    errors.append(f"{where}: unknown core module {other}")
                elif other != module and LAYERS[other] >= LAYERS[module]:
                    errors.append(f"{where}: core/{module} (layer {LAYERS[module]}) may include "
                                  f"only lower layers, not core/{other} (layer {LAYERS[other]})")
        elif top == "client":
            if inc_parts[0] == "server" and inc_parts[1:2] != ["serialization"]:
                errors.append(f"{where}: the client shares only server/serialization")
    return errors


def main() -> int:
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else
                        pathlib.Path(__file__).resolve().parent.parent)
    errors = []
    checked = 0
    for top in ("common", "storage", "core", "server", "client"):
        for path in sorted((root / top).rglob("*")):
            if path.suffix not in (".h", ".cc") or not path.is_file():
                continue
            rel = pathlib.PurePosixPath(path.relative_to(root).as_posix())
            errors += check_file(rel, path.read_text(errors="replace"))
            checked += 1
    for error in errors:
        print(error)
    if errors:
        print(f"check_layers: {len(errors)} include(s) break the layer rule "
              f"({checked} files checked)", file=sys.stderr)
        return 1
    print(f"check_layers: {checked} files follow the layer rule")
    return 0


if __name__ == "__main__":
    sys.exit(main())
