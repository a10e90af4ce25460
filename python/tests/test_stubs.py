"""The type hints (atmosim/__init__.pyi, atmosim/_atmosim.pyi) against the
installed package: mypy's stubtest finds every name, signature and class
of the stubs at run time and nothing public left out."""

import subprocess
import sys

import pytest


def test_the_stubs_are_the_package(tmp_path):
    pytest.importorskip("mypy")
    p = subprocess.run([sys.executable, "-m", "mypy.stubtest", "atmosim"], capture_output=True, text=True,
                       cwd=tmp_path)
    assert p.returncode == 0, p.stdout + p.stderr
