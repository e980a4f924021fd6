"""Shared fixtures: the workspace's models, example-robot-data's URDFs, Pinocchio's mapping."""

import os
import sysconfig

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
MODELS = os.path.join(ROOT, "models")


def model_path(name):
    return os.path.join(MODELS, name)


def robots_dir():
    """example-robot-data's robots/ directory in this Python, or None."""
    for key in ("purelib", "platlib"):
        d = os.path.join(sysconfig.get_paths()[key],
                         "cmeel.prefix", "share", "example-robot-data", "robots")
        if os.path.isdir(d):
            return d
    return None


def example_robot_urdfs():
    """Every .urdf of example-robot-data as (key, path), sorted."""
    d = robots_dir()
    if d is None:
        return []
    out = []
    for dirpath, _, files in os.walk(d):
        for f in files:
            if f.endswith(".urdf"):
                p = os.path.join(dirpath, f)
                out.append((os.path.relpath(p, d)[:-5], p))
    return sorted(out)


@pytest.fixture(scope="session")
def root():
    return ROOT
