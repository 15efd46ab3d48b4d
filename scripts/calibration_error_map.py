#!/usr/bin/python3
"""Where in the image an estimated stereo calibration makes depth wrong, against the true calibration.

For a grid of pixels of the TRUE rectified left image, the point at depth Z on that pixel's ray is projected
into the raw left and right images with the TRUE camera models (OpenCV's plumb-bob distortion), then rectified
with the ESTIMATED calibration (cv2.stereoRectify with CALIB_ZERO_DISPARITY, alpha 0, as linesight's
rectifier), and triangulated back: Z_est = f_est * B_est / (x_left - x_right). Prints the relative depth error
(%) and the vertical misalignment y_left - y_right (px) on the grid. What it isolates is the calibration alone:
no images, no matching.

    /usr/bin/python3 scripts/calibration_error_map.py TRUE.yml ESTIMATED.yml [--depth 2.0] [--step 40] \
        [--at U,V ...]

--at U,V also prints the two values at that pixel of the true rectified left image (e.g. an obstacle's
`nearest_pixel` from `linesight render`'s obstacles.json).

TRUE.yml: the `stereo.yml` that `linesight render` writes beside a scene; ESTIMATED.yml: `linesight calibrate
--out` (or `linesight demo`'s stereo.yml). Both are linesight calibration files (OpenCV FileStorage YAML with
image_width, image_height, M1 D1 M2 D2 R T). Exit status 2 when a file is unusable.
"""
import argparse
import sys

import cv2
import numpy as np


def fail(message):
    print(message, file=sys.stderr)
    sys.exit(2)


def load(path):
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    if not fs.isOpened():
        fail(f"{path}: cannot open as an OpenCV YAML file")
    calib = {}
    for key in ("M1", "D1", "M2", "D2", "R", "T"):
        m = fs.getNode(key).mat()
        if m is None:
            fail(f"{path}: field {key} is missing (expected a linesight/OpenCV stereo calibration)")
        calib[key] = m
    w, h = int(fs.getNode("image_width").real()), int(fs.getNode("image_height").real())
    if w <= 0 or h <= 0:
        fail(f"{path}: image_width / image_height missing or not positive")
    calib["size"] = (w, h)
    return calib


def rectify(c):
    r1, r2, p1, p2, _, _, _ = cv2.stereoRectify(c["M1"], c["D1"], c["M2"], c["D2"], c["size"], c["R"], c["T"],
                                                flags=cv2.CALIB_ZERO_DISPARITY, alpha=0)
    return r1, r2, p1, p2


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("true_calibration")
    parser.add_argument("estimated_calibration")
    parser.add_argument("--depth", type=float, default=2.0, help="depth Z of the points (m)")
    parser.add_argument("--step", type=int, default=40, help="grid step (px)")
    parser.add_argument("--at", action="append", default=[], metavar="U,V",
                        help="also report this true rectified left pixel (repeatable)")
    args = parser.parse_args()
    if args.depth <= 0 or args.step <= 0:
        parser.error("--depth and --step must be positive")
    true, est = load(args.true_calibration), load(args.estimated_calibration)
    if true["size"] != est["size"]:
        fail(f"image sizes differ: {true['size']} vs {est['size']}")
    w, h = true["size"]
    r1, _, p1, _ = rectify(true)
    r1e, r2e, p1e, p2e = rectify(est)
    f, cx, cy = p1[0, 0], p1[0, 2], p1[1, 2]
    z = args.depth
    grid_u, grid_v = np.meshgrid(np.arange(args.step // 2, w, args.step), np.arange(args.step // 2, h, args.step))
    points = []
    for text in args.at:
        try:
            u, v = (float(t) for t in text.split(","))
        except ValueError:
            parser.error(f"--at {text!r}: expected U,V (two numbers)")
        points.append((u, v))
    # The grid's pixels, then the --at pixels, in one pass.
    us = np.concatenate([grid_u.ravel(), [p[0] for p in points]]).astype(np.float64)
    vs = np.concatenate([grid_v.ravel(), [p[1] for p in points]]).astype(np.float64)
    grid_shape, n = grid_u.shape, grid_u.size
    rect = np.stack([(us - cx) / f * z, (vs - cy) / f * z, np.full(us.shape, z)], -1).reshape(-1, 3)
    left = (r1.T @ rect.T).T  # true left camera frame
    q_left, _ = cv2.projectPoints(left, np.zeros(3), np.zeros(3), true["M1"], true["D1"])
    rvec, _ = cv2.Rodrigues(true["R"])
    q_right, _ = cv2.projectPoints(left, rvec, true["T"].ravel(), true["M2"], true["D2"])
    el = cv2.undistortPoints(q_left, est["M1"], est["D1"], R=r1e, P=p1e).reshape(-1, 2)
    er = cv2.undistortPoints(q_right, est["M2"], est["D2"], R=r2e, P=p2e).reshape(-1, 2)
    disparity = el[:, 0] - er[:, 0]
    z_est = -p2e[0, 3] / disparity
    rel = (z_est - z) / z * 100.0
    dy = el[:, 1] - er[:, 1]
    gu, gv, grel, gdy = us[:n], vs[:n], rel[:n], dy[:n]
    np.set_printoptions(linewidth=250, precision=2, suppress=True, threshold=100000)
    cols = f"u = {gu[0]:.0f}..{gu[grid_shape[1] - 1]:.0f} step {args.step}"
    rows = f"v = {gv[0]:.0f}..{gv[-1]:.0f} step {args.step}"
    print(f"relative depth error (%) at Z = {z:g} m (rows: {rows}; columns: {cols}):")
    print(grel.reshape(grid_shape))
    print("vertical misalignment y_left - y_right (px):")
    print(gdy.reshape(grid_shape))
    inner = (gu > w * 0.1) & (gu < w * 0.9) & (gv > h * 0.1) & (gv < h * 0.9)
    print(f"max |depth error|: {np.abs(grel).max():.2f} % overall, "
          f"{np.abs(grel[inner]).max():.2f} % inside the central 80 % of width and height")
    for i, (u, v) in enumerate(points):
        print(f"at ({u:g}, {v:g}): depth error {rel[n + i]:+.2f} %, vertical misalignment {dy[n + i]:+.3f} px")


if __name__ == "__main__":
    main()
