"""A real semmapd on loopback for the client tests: the binary from $SEMMAPD (ctest sets it)
or the release build; skipped, saying why, when neither exists."""
import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parent.parent.parent
sys.path.insert(0, str(HERE.parent))  # the package in place

SAMPLE = REPO / "data" / "samples" / "tum_fr3_teddy_80"
TEDDY_PHOTO = REPO / "data" / "samples" / "objects" / "teddy.png"


def _semmapd() -> pathlib.Path:
    path = pathlib.Path(os.environ.get("SEMMAPD", REPO / "build" / "release" / "server" /
                                       "semmapd"))
    if not path.is_file():
        pytest.skip(f"no semmapd at {path} (build it, or set $SEMMAPD)")
    return path


class Server:
    def __init__(self, data_dir: pathlib.Path, *flags: str):
        self.process = subprocess.Popen(
            [str(_semmapd()), "--listen", "127.0.0.1:0", "--data-dir", str(data_dir),
             "--log-level", "warning", *flags],
            stdout=subprocess.PIPE, text=True)
        deadline = time.monotonic() + 30
        self.address = None
        while time.monotonic() < deadline:
            line = self.process.stdout.readline()
            if not line:
                break
            if "listening on " in line:
                self.address = line.split("listening on ", 1)[1].strip()
                break
        if self.address is None:
            self.process.kill()
            raise RuntimeError("semmapd did not start")

    def stop(self) -> int:
        self.process.send_signal(signal.SIGTERM)
        try:
            return self.process.wait(timeout=60)
        finally:
            self.process.stdout.close()


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    started = Server(tmp_path_factory.mktemp("semmapd"))
    yield started
    assert started.stop() == 0, "semmapd did not drain and exit 0 on SIGTERM"


@pytest.fixture
def client(server):
    import semmap

    with semmap.Client(server.address, timeout=60) as connected:
        yield connected
