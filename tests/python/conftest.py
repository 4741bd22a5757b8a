"""Shared fixtures: the laydown binary and a quickstart archive built once per session."""
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def laydown_bin():
    path = os.environ.get("LAYDOWN_BIN", str(ROOT / "target" / "release" / "laydown"))
    if not pathlib.Path(path).exists():
        pytest.fail(f"laydown binary not found at {path}; build it (cargo build --release) or set LAYDOWN_BIN")
    return path


@pytest.fixture(scope="session")
def quickstart_archive(laydown_bin, tmp_path_factory):
    out = tmp_path_factory.mktemp("quickstart") / "quickstart.h5"
    subprocess.run(
        [laydown_bin, "run", str(ROOT / "pipelines" / "quickstart.yaml"), "--archive", str(out)],
        check=True,
        cwd=ROOT,
        capture_output=True,
    )
    return out
