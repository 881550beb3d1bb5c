"""The committed stubs are what protoc makes of proto/ today (never edited, never stale)."""
import importlib.util
import pathlib
import shutil

import pytest

HERE = pathlib.Path(__file__).resolve().parent
PACKAGE = HERE.parent


def _generator():
    spec = importlib.util.spec_from_file_location("generate_stubs",
                                                  PACKAGE / "generate_stubs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_committed_stubs_match_the_proto(tmp_path):
    if shutil.which("protoc") is None or shutil.which("grpc_python_plugin") is None:
        pytest.skip("protoc or grpc_python_plugin is not installed")
    fresh = _generator().generate(tmp_path)
    assert fresh, "generate_stubs wrote nothing"
    for path in fresh:
        committed = PACKAGE / "semmap" / "v1" / path.name
        assert committed.is_file(), f"{committed} is missing: run generate_stubs.py"
        assert committed.read_bytes() == path.read_bytes(), (
            f"{committed.name} is out of step with proto/: run client/python/generate_stubs.py")
