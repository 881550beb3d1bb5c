import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
TRAINING = os.path.dirname(HERE)
ROOT = os.path.dirname(TRAINING)
sys.path.insert(0, TRAINING)

import torch  # noqa: E402

torch.set_num_threads(1)


def synth_binary():
    return os.environ.get("SEMMAP_SYNTH", os.path.join(ROOT, "build", "release", "tools", "semmap-synth"))


def pytest_configure(config):
    config.addinivalue_line("markers", "slow: takes more than a few seconds (deselect with -m 'not slow')")


@pytest.fixture(scope="session")
def synth_seq(tmp_path_factory):
    """A small semmap-synth sequence (skips when the generator is not built)."""
    import subprocess
    exe = synth_binary()
    if not os.access(exe, os.X_OK):
        pytest.skip(f"{exe} not built (make build)")
    out = tmp_path_factory.mktemp("synth") / "seq"
    subprocess.run([exe, str(out), "--trajectory", "circle", "--frames", "200", "--seed", "5", "--width", "192",
                    "--height", "144", "--quiet", "--no-templates"], check=True)
    return str(out)


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    """Keep the frame cache of tests out of the user's cache."""
    from semmap_vo import config as C
    monkeypatch.setattr(C, "CACHE_DIR", str(tmp_path / "cache"))
