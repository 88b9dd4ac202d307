"""Shared test helpers. Blender tests live in tests/blender and run bpy in subprocesses."""

import json
import warnings

import numpy as np
import pytest

warnings.filterwarnings("ignore", module="colour")


@pytest.fixture
def core():
    """The compiled module, imported lazily so collection works without a build."""
    from polychrome import _core

    return _core


def settings_json(**kw):
    return json.dumps(kw)


def luminance(rgb):
    rgb = np.asarray(rgb, dtype=np.float64)
    return 0.2126 * rgb[..., 0] + 0.7152 * rgb[..., 1] + 0.0722 * rgb[..., 2]
