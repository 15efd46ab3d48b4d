import os
import pathlib

import pytest

OPENCV_DATA = pathlib.Path(os.environ.get("LINESIGHT_OPENCV_DATA_DIR",
                                          "/usr/share/doc/opencv-doc/examples/data"))


@pytest.fixture(scope="session")
def aloe():
    """opencv-doc's Middlebury Aloe pair as the CLI reads it (uint8 BGR)."""
    import linesight
    left, right = OPENCV_DATA / "aloeL.jpg", OPENCV_DATA / "aloeR.jpg"
    if not left.exists():
        if os.environ.get("CI") == "true":
            pytest.fail(f"{left} is missing (install opencv-doc)")
        pytest.skip(f"{left} is missing (install opencv-doc)")
    return left, right, linesight.read_image(left), linesight.read_image(right)


@pytest.fixture(scope="session")
def scene():
    """The synthetic power line, seed 3, with its default damper / clamp / insulator string."""
    import linesight
    return linesight.render_scene(seed=3, supersampling=1)


@pytest.fixture(scope="session")
def cli():
    """The built `linesight` CLI (the ctest test sets LINESIGHT_BINARY)."""
    path = os.environ.get("LINESIGHT_BINARY")
    if not path:
        pytest.skip("LINESIGHT_BINARY is not set (ctest sets it to the built CLI)")
    return path
