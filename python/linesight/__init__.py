"""linesight: binocular stereo vision ranging.

numpy arrays in and out: images are uint8 (H, W) grey or (H, W, 3) BGR (OpenCV's order), disparity
maps float32 (H, W) in pixels with +inf where there is no estimate, depths in metres. Every function
calls the C++ library as the ``linesight`` CLI does, so results equal the CLI's bit for bit.

Errors raise :class:`InputError` (bad input: a file, field or value, named in the message),
:class:`OptionError` (an option out of its range; an InputError) or :class:`UsageError` (an unknown
method, parameter or setting). All three are ValueErrors.

Example::

    import linesight
    scene = linesight.render_scene(seed=3)                     # the synthetic power line
    pipeline = linesight.RangingPipeline(scene["calibration"])  # isgm over 0.3..6 m
    result = pipeline.range(scene["left"], scene["right"], auto=True)
    for obstacle in result["obstacles"]:
        print(obstacle["distance_m"], obstacle["sigma_m"])
"""

from ._core import (
    InputError,
    Matcher,
    OptionError,
    RangingPipeline,
    Rectifier,
    StereoCalibration,
    UsageError,
    calibrate_stereo,
    calibrate_stereo_from_corners,
    compute_disparity,
    default_matcher,
    depth_from_disparity,
    detect_pattern,
    matcher_help,
    matchers,
    point_cloud,
    ranging_settings,
    read_image,
    read_pfm,
    render_scene,
    write_pfm,
)

__all__ = [
    "InputError",
    "Matcher",
    "OptionError",
    "RangingPipeline",
    "Rectifier",
    "StereoCalibration",
    "UsageError",
    "calibrate_stereo",
    "calibrate_stereo_from_corners",
    "compute_disparity",
    "default_matcher",
    "depth_from_disparity",
    "detect_pattern",
    "matcher_help",
    "matchers",
    "point_cloud",
    "ranging_settings",
    "read_image",
    "read_pfm",
    "render_scene",
    "write_pfm",
]
