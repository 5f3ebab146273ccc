"""Shared fixtures. Tests never download anything; data is generated here."""

from __future__ import annotations

import os
from pathlib import Path

import pytest


@pytest.fixture
def isolated_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A fresh, empty manigrasp cache for one test."""
    root = tmp_path / "cache"
    monkeypatch.setenv("MANIGRASP_CACHE", str(root))
    return root


def pytest_configure(config: pytest.Config) -> None:
    # Keep CoACD / OpenMP from oversubscribing the 2-core CI machine.
    os.environ.setdefault("OMP_NUM_THREADS", "1")
