"""Shared test set-up: the repository root on sys.path and paths to the bundled CMU clips."""

import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


@pytest.fixture(scope="session")
def data_dir():
    return DATA


@pytest.fixture(autouse=True)
def _private_signature_cache(tmp_path_factory, monkeypatch):
    """``rank`` caches signatures per user by default: tests use a fresh folder, never the user's."""
    monkeypatch.setenv("SHAPESIG_CACHE_DIR", str(tmp_path_factory.mktemp("signature_cache")))
