"""The scripts of examples/python run (their quick variants) and write what they say."""

import os
import subprocess
import sys

import pytest

from conftest import ROOT

EXAMPLES = os.path.join(ROOT, "examples", "python")


def run(name, *args):
    r = subprocess.run([sys.executable, os.path.join(EXAMPLES, name), "--quick", *args],
                       capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-3000:]
    return r.stdout


def test_humanoid():
    out = run("humanoid.py")
    assert "linear momentum" in out and "= mass × ċ: True" in out


def test_crowd(tmp_path):
    out = run("crowd.py", "--out", str(tmp_path))
    frames = sorted(p for p in os.listdir(tmp_path) if p.startswith("frame_"))
    assert frames == ["frame_00000.png", "frame_00030.png", "frame_00060.png"], out
    assert all(os.path.getsize(tmp_path / f) > 1000 for f in frames)


def test_rollout(tmp_path):
    pytest.importorskip("matplotlib", reason="matplotlib is not installed")
    png = tmp_path / "energy.png"
    out = run("rollout.py", "--out", str(png))
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", out
