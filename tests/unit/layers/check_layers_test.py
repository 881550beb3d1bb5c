#!/usr/bin/env python3
"""scripts/check_layers.py finds each kind of broken include in a small tree, and passes a
clean one."""
import pathlib
import subprocess
import sys
import tempfile
import unittest

SCRIPT = pathlib.Path(__file__).resolve().parents[3] / "scripts" / "check_layers.py"


def run(files: dict) -> subprocess.CompletedProcess:
    with tempfile.TemporaryDirectory() as root:
        for rel, text in files.items():
            path = pathlib.Path(root, rel)
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        return subprocess.run([sys.executable, str(SCRIPT), root], capture_output=True,
                              text=True, check=False)


CLEAN = {
    "common/status.h": "#include <string>\n",
    "storage/map_store.h": '#include "common/status.h"\n',
    "core/sensor/frame.h": '#include "common/status.h"\n',
    "core/odometry/tracker.h": '#include "core/sensor/frame.h"\n#include "core/odometry/internal/lm.h"\n',
    "core/odometry/internal/lm.h": "\n",
    "core/pipeline/session.h": '#include "core/odometry/tracker.h"\n#include "storage/map_store.h"\n',
    "server/service.cc": '#include "core/pipeline/session.h"\n#include "semmap/v1/service.pb.h"\n',
    "client/lib/client.cc": '#include "server/serialization/conversions.h"\n',
}


class CheckLayersTest(unittest.TestCase):
    def test_clean_tree_passes(self):
        result = run(CLEAN)
        self.assertEqual(result.returncode, 0, result.stdout + result.stderr)

    def assert_refused(self, rel, text, expected):
        files = dict(CLEAN)
        files[rel] = text
        result = run(files)
        self.assertEqual(result.returncode, 1, result.stdout)
        self.assertIn(expected, result.stdout)
        self.assertIn(rel, result.stdout)

    def test_upward_and_sideways_includes_are_refused(self):
        self.assert_refused("core/odometry/bad.h", '#include "core/pipeline/session.h"\n',
                            "may include only lower layers")
        self.assert_refused("core/mapping/bad.h", '#include "core/recognition/x.h"\n',
                            "may include only lower layers")

    def test_service_proto_and_grpc_are_refused_in_core(self):
        for inc in ('"server/semmap_server.h"', '"semmap/v1/service.pb.h"',
                    "<grpcpp/grpcpp.h>", "<google/protobuf/message.h>"):
            self.assert_refused("core/slam/bad.h", f"#include {inc}\n", "without the service")

    def test_internal_headers_stay_in_their_module(self):
        self.assert_refused("core/slam/bad.cc", '#include "core/odometry/internal/lm.h"\n',
                            "private to that module")

    def test_lower_layers_include_nothing_above(self):
        self.assert_refused("storage/bad.cc", '#include "core/sensor/frame.h"\n',
                            "storage/ depends only on common/")
        self.assert_refused("common/bad.h", '#include "storage/map_store.h"\n',
                            "bottom layer")

    def test_client_shares_only_serialization(self):
        self.assert_refused("client/lib/bad.cc", '#include "server/semmap_server.h"\n',
                            "only server/serialization")


if __name__ == "__main__":
    unittest.main()
