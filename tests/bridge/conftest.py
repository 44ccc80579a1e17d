"""Fixtures of the over-the-wire tests."""

from __future__ import annotations

import pytest
from wire_doubles import MISSIONS

from cptbt.loader import load_mission
from cptbt.mission import MissionBase


@pytest.fixture(scope="session")
def msn007() -> MissionBase:
    return load_mission(MISSIONS / "tro2006_msn007.yaml")
