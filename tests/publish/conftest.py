"""A small real board set (D1, D2 and a D3-shaped config), built and published once per session;
tests that damage a set work on a copy (`published_copy`)."""
from __future__ import annotations

import shutil

import pytest

from pcbdata.publish import publish_set
from tests.publish.setbuilder import make_set


@pytest.fixture(scope="session")
def published(tmp_path_factory):
    root = tmp_path_factory.mktemp("published") / "set"
    make_set(root)
    publish_set(root, previews=2)
    return root


@pytest.fixture
def published_copy(published, tmp_path):
    root = tmp_path / "set"
    shutil.copytree(published, root)
    return root
