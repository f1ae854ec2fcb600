"""Shared fixtures of the Python module's tests (ctest runs them: tests/CMakeLists.txt).

The module is imported from PYTHONPATH (the build's python/ folder); the
command line from LSDEM_BINARY; scenes from LSDEM_SOURCE_DIR (default: this
checkout).
"""

import os
import pathlib

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("LSDEM_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
THREE_GRAINS_2D = SOURCE_DIR / "apps" / "scenes" / "three_grains" / "three_grains_2d.toml"

# Steps of the short runs: the platen reaches the stack and the first two
# grains break (at steps 7,500-9,000; the tests check that they did), in
# about 0.2 s of stepping.
SHORT_STEPS = 10000


@pytest.fixture(scope="session")
def scene_path():
    assert THREE_GRAINS_2D.is_file(), THREE_GRAINS_2D
    return str(THREE_GRAINS_2D)


@pytest.fixture(scope="session")
def lsdem_binary():
    binary = os.environ.get("LSDEM_BINARY")
    if not binary:
        pytest.skip("LSDEM_BINARY (the lsdem command line) is not set")
    assert os.access(binary, os.X_OK), binary
    return binary
