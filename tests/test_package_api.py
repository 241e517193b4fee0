"""The packages' public API: every re-exported name resolves, and importing the light modules
stays light (the CLI imports the error classes at start-up)."""

from __future__ import annotations

import subprocess
import sys

import pytest

import perception
import planner


@pytest.mark.parametrize("package", [planner, perception], ids=lambda p: p.__name__)
def test_every_exported_name_resolves(package):
    for name in package.__all__:
        assert getattr(package, name) is not None


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError):
        _ = planner.no_such_thing


def test_light_imports_stay_light():
    code = (
        "import sys, perception.codes, perception.errors, planner.errors; "
        "print(any(m in sys.modules for m in ('cv2', 'sklearn', 'ruckig', 'mujoco')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
