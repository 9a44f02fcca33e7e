"""Tests needing ../shared/data skip with a message saying how to get it, and fail instead under
CI (the ``CI`` environment variable set), where a missing folder is a broken checkout."""

from __future__ import annotations

import conftest
import pytest


@pytest.fixture
def no_data(monkeypatch, tmp_path):
    """The shared folders pointed at an empty directory."""
    monkeypatch.setattr(conftest, "SHARED_BVH", tmp_path / "bvh")
    monkeypatch.setattr(conftest, "SHARED_REAL", tmp_path / "real")
    return tmp_path


@pytest.mark.parametrize("value", ["", "0", "false"])
def test_missing_data_skips_with_how_to_get_it(no_data, monkeypatch, value):
    monkeypatch.setenv("CI", value)
    for fetch, name in ((conftest.shared_clip, "walk60.bvh"), (conftest.real_export, "x.bvh")):
        with pytest.raises(pytest.skip.Exception) as e:
            fetch(name)
        assert str(no_data) in str(e.value) and "../shared/data" in str(e.value)


@pytest.mark.parametrize("value", ["true", "1", "yes"])
def test_missing_data_fails_under_ci(no_data, monkeypatch, value):
    monkeypatch.setenv("CI", value)
    for fetch, name in ((conftest.shared_clip, "walk60.bvh"), (conftest.real_export, "x.bvh")):
        with pytest.raises(pytest.fail.Exception, match=r"CI is set but .*\.\./shared/data"):
            fetch(name)


def test_present_data_is_found():
    assert conftest.shared_clip("walk60.bvh") == conftest.SHARED_BVH / "walk60.bvh"
