"""Shared fixtures: the repository root and the `mpm` program to compare against."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


def _mpm_binary() -> pathlib.Path:
    """$MPM_BIN, else target/release/mpm or target/debug/mpm, else built with cargo."""
    env = os.environ.get("MPM_BIN")
    if env:
        return pathlib.Path(env)
    for profile in ("release", "debug"):
        candidate = ROOT / "target" / profile / "mpm"
        if candidate.exists():
            return candidate
    subprocess.run(["cargo", "build", "--release", "--bin", "mpm"], cwd=ROOT, check=True)
    return ROOT / "target" / "release" / "mpm"


@pytest.fixture(scope="session")
def root() -> pathlib.Path:
    return ROOT


@pytest.fixture(scope="session")
def run_mpm():
    """Runs the mpm program with the given arguments and returns its standard output."""
    binary = _mpm_binary()

    def run(*args) -> str:
        done = subprocess.run([str(binary), *map(str, args)], cwd=ROOT, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
        return done.stdout

    return run
