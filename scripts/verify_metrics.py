#!/usr/bin/python3
"""Independent re-computation of the disparity metrics in a `linesight eval stereo` JSON report.

It reads the benchmark ground truth with its own loader code (numpy + OpenCV's Python bindings only, nothing
from linesight's C++), reads the disparity maps that `eval stereo --save-disparity DIR` wrote as
DIR/<set>/<scene>/<method>.pfm, recomputes every metric of every region listed in the report and prints the
largest absolute difference per metric. Exit status: 0 when every difference is within the tolerance
(default 0.01: percentage points for the percentages, px for avgerr / RMSE) and every pixel count matches,
1 when something differs, 2 when the input is unusable.

    /usr/bin/python3 scripts/verify_metrics.py --data ../shared/data --disparities DIR --json report.json

Definitions (DESIGN.md "Metrics"): over the pixels of a region with known (finite) ground truth,
e = |d - d_gt|; bad-tau: e > tau (tau = 0.5, 1, 2, 4); D1: e > 3 and e > 0.05 * |d_gt|. Dense variant: a pixel
without a finite estimate counts as bad, percent of evaluated; sparse variant: percent of estimated pixels.
density = estimated / evaluated; avgerr and RMSE over estimated pixels. A ratio with a zero denominator is 0.

Regions, per layout (as the C++ loader documents them in src/linesight/eval/dataset.h):
  Middlebury 2001/2003: gt = groundtruth.png / scale (info.txt line 1), 0 unknown; all/nonocc/disc =
      <region>.png == 255 and known.
  Middlebury 2005/2006 half: gt = disp1.png / 2; nonocc: x_r = floor(x - d1 + 0.5) inside the image, disp5 at
      x_r known and |d1 - d5| <= 1.
  Middlebury 2014: gt = disp0GT.pfm; nonocc = mask0nocc.png == 255 and known.
  ETH3D: gt = disp0.pfm; nonocc = mask0nocc.png == 255 if present, else all.
  KITTI 2015: gt = disp_occ_0/F_10.png / 256, 0 unknown; nonocc from disp_noc_0 if present.
  Scene Flow: gt = disparity/left/X.pfm; nonocc = occlusion/left/X.png == 0 and known.
  opencv-doc Aloe: gt = aloeGT.png (scale 1), 0 unknown.
"""

import argparse
import json
import math
import os
import sys

import cv2
import numpy as np

THRESHOLDS = [(0.5, "0.5"), (1.0, "1"), (2.0, "2"), (4.0, "4")]
COUNT_KEYS = ["evaluated", "estimated"]
VALUE_KEYS = (["density"] + ["bad_" + name for _, name in THRESHOLDS] + ["d1"] +
              ["bad_" + name + "_sparse" for _, name in THRESHOLDS] + ["d1_sparse", "avgerr", "rmse"])
LR_TOLERANCE_PX = 1.0


class InputProblem(Exception):
    pass


# ----------------------------------------------------------------------------------------------------------
# File formats.

def read_pfm(path):
    """PFM as Middlebury uses it: the sign of the scale gives the byte order (negative = little-endian),
    rows are stored bottom-up."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise InputProblem(f"{path}: cannot read: {e.strerror}")
    tokens, pos = [], 0
    while len(tokens) < 4:
        while pos < len(data) and data[pos:pos + 1].isspace():
            pos += 1
        start = pos
        while pos < len(data) and not data[pos:pos + 1].isspace():
            pos += 1
        if start == pos:
            raise InputProblem(f"{path}: truncated PFM header")
        tokens.append(data[start:pos].decode("ascii", "replace"))
    pos += 1  # the single whitespace character after the scale
    magic, width, height, scale = tokens[0], int(tokens[1]), int(tokens[2]), float(tokens[3])
    if magic not in ("Pf", "PF"):
        raise InputProblem(f"{path}: not a PFM file (magic {magic!r})")
    channels = 3 if magic == "PF" else 1
    dtype = np.dtype("<f4") if scale < 0 else np.dtype(">f4")
    count = width * height * channels
    if len(data) - pos < count * 4:
        raise InputProblem(f"{path}: truncated PFM data")
    values = np.frombuffer(data, dtype=dtype, count=count, offset=pos).astype(np.float32)
    image = values.reshape(height, width, channels) if channels == 3 else values.reshape(height, width)
    return np.flipud(image).copy()


def read_grey(path):
    """8/16-bit single-channel values; palette PNGs are mapped to grey by OpenCV's GRAYSCALE reader."""
    if not os.path.isfile(path):
        raise InputProblem(f"{path}: no such file")
    # IMREAD_UNCHANGED would expand a palette PNG to BGR; the grey reader maps it through the palette.
    image = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise InputProblem(f"{path}: cannot decode image")
    return image


def integer_disparity(path, scale):
    values = read_grey(path)
    gt = values.astype(np.float32) / np.float32(scale)
    gt[values == 0] = np.inf
    return gt


def finite_or_inf(array):
    out = array.astype(np.float32).copy()
    out[~np.isfinite(out)] = np.inf
    return out


# ----------------------------------------------------------------------------------------------------------
# Loaders: each returns (gt float32 with inf unknown, {region: bool mask}).

def load_middlebury_2001(scene_dir):
    with open(os.path.join(scene_dir, "info.txt")) as f:
        scale = float(f.read().split()[0])
    gt = integer_disparity(os.path.join(scene_dir, "groundtruth.png"), scale)
    known = np.isfinite(gt)
    masks = {}
    for region in ("all", "nonocc", "disc"):
        masks[region] = (read_grey(os.path.join(scene_dir, region + ".png")) == 255) & known
    return gt, masks


def load_middlebury_2005(scene_dir):
    gt = integer_disparity(os.path.join(scene_dir, "disp1.png"), 2.0)
    gt_right = integer_disparity(os.path.join(scene_dir, "disp5.png"), 2.0)
    height, width = gt.shape
    known = np.isfinite(gt)
    xs = np.tile(np.arange(width, dtype=np.float64), (height, 1))
    d = np.where(known, gt.astype(np.float64), 0.0)
    x_right = np.floor(xs - d + 0.5)
    inside = known & (x_right >= 0) & (x_right < width)
    rows = np.tile(np.arange(height)[:, None], (1, width))
    d_right = np.full(gt.shape, np.inf, dtype=np.float32)
    d_right[inside] = gt_right[rows[inside], x_right[inside].astype(np.int64)]
    with np.errstate(invalid="ignore"):  # inf - inf where either side is unknown; those are excluded anyway
        consistent = np.abs(gt - d_right) <= LR_TOLERANCE_PX
    nonocc = inside & np.isfinite(d_right) & consistent
    return gt, {"all": known, "nonocc": nonocc}


def load_middlebury_2014(scene_dir, gt_name, mask_required):
    gt = finite_or_inf(read_pfm(os.path.join(scene_dir, gt_name)))
    known = np.isfinite(gt)
    mask_path = os.path.join(scene_dir, "mask0nocc.png")
    if os.path.isfile(mask_path) or mask_required:
        nonocc = (read_grey(mask_path) == 255) & known
    else:
        nonocc = known.copy()
    return gt, {"all": known, "nonocc": nonocc}


def load_kitti(training_dir, frame):
    def kitti(path):
        values = cv2.imread(path, cv2.IMREAD_UNCHANGED)
        if values is None:
            raise InputProblem(f"{path}: cannot read KITTI disparity")
        gt = values.astype(np.float32) / np.float32(256.0)
        gt[values == 0] = np.inf
        return gt

    gt = kitti(os.path.join(training_dir, "disp_occ_0", frame + ".png"))
    known = np.isfinite(gt)
    masks = {"all": known}
    noc_path = os.path.join(training_dir, "disp_noc_0", frame + ".png")
    if os.path.isfile(noc_path):
        masks["nonocc"] = np.isfinite(kitti(noc_path)) & known
    return gt, masks


def load_sceneflow(set_dir, frame):
    gt = finite_or_inf(read_pfm(os.path.join(set_dir, "disparity", "left", frame + ".pfm")))
    known = np.isfinite(gt)
    masks = {"all": known}
    occlusion = os.path.join(set_dir, "occlusion", "left", frame + ".png")
    if os.path.isfile(occlusion):
        masks["nonocc"] = (read_grey(occlusion) == 0) & known
    return gt, masks


def load_aloe(folder):
    gt = integer_disparity(os.path.join(folder, "aloeGT.png"), 1.0)
    return gt, {"all": np.isfinite(gt)}


# ----------------------------------------------------------------------------------------------------------
# Scene discovery: {(set, scene): loader}.

def find_scenes(root):
    if not os.path.isdir(root):
        raise InputProblem(f"{root}: no such folder")
    scenes = {}

    def parent_name(path):
        return os.path.basename(os.path.dirname(os.path.abspath(path)))

    for folder, subdirs, files in os.walk(root):
        names = set(files)
        folder_name = os.path.basename(os.path.abspath(folder))
        leaf = True
        if {"imL.png", "imR.png"} <= names and ({"groundtruth.png", "info.txt"} & names):
            scenes[(parent_name(folder), folder_name)] = lambda f=folder: load_middlebury_2001(f)
        elif {"view1.png", "view5.png", "disp1.png"} <= names:
            scenes[(parent_name(folder), folder_name)] = lambda f=folder: load_middlebury_2005(f)
        elif {"im0.png", "im1.png", "disp0GT.pfm"} <= names:
            scenes[(parent_name(folder), folder_name)] = lambda f=folder: load_middlebury_2014(f, "disp0GT.pfm", True)
        elif {"im0.png", "im1.png", "disp0.pfm"} <= names:
            scenes[(parent_name(folder), folder_name)] = lambda f=folder: load_middlebury_2014(f, "disp0.pfm", False)
        elif {"aloeL.jpg", "aloeR.jpg", "aloeGT.png"} <= names:
            scenes[("opencv-aloe", "aloe")] = lambda f=folder: load_aloe(f)
            leaf = False
        elif all(os.path.isdir(os.path.join(folder, d)) for d in ("image_2", "image_3", "disp_occ_0")):
            set_name = parent_name(folder) if folder_name in ("training", "testing") else folder_name
            for file in os.listdir(os.path.join(folder, "image_2")):
                stem, ext = os.path.splitext(file)
                if ext == ".png" and stem.endswith("_10"):
                    scenes[(set_name, stem[:-3])] = lambda f=folder, s=stem: load_kitti(f, s)
        elif (os.path.isdir(os.path.join(folder, "RGB_cleanpass", "left")) and
              os.path.isdir(os.path.join(folder, "disparity", "left"))):
            for file in os.listdir(os.path.join(folder, "RGB_cleanpass", "left")):
                stem, ext = os.path.splitext(file)
                if ext == ".png":
                    scenes[(folder_name, stem)] = lambda f=folder, s=stem: load_sceneflow(f, s)
        else:
            leaf = False
        if leaf:
            subdirs[:] = []  # a dataset folder: its children are part of it
    return scenes


# ----------------------------------------------------------------------------------------------------------
# Metrics.

def percent(count, total):
    return 100.0 * count / total if total > 0 else 0.0


def compute_metrics(disparity, gt, mask):
    selected = mask & np.isfinite(gt)
    gt_values = gt[selected].astype(np.float64)
    d_values = disparity[selected].astype(np.float64)
    evaluated = int(gt_values.size)
    has_estimate = np.isfinite(d_values)
    estimated = int(has_estimate.sum())
    missing = evaluated - estimated
    error = np.abs(d_values[has_estimate] - gt_values[has_estimate])
    gt_of_estimated = np.abs(gt_values[has_estimate])
    result = {"evaluated": evaluated, "estimated": estimated, "density": percent(estimated, evaluated)}
    bad_counts = {name: int((error > tau).sum()) for tau, name in THRESHOLDS}
    d1_count = int(((error > 3.0) & (error > 0.05 * gt_of_estimated)).sum())
    for _, name in THRESHOLDS:
        result["bad_" + name] = percent(bad_counts[name] + missing, evaluated)
        result["bad_" + name + "_sparse"] = percent(bad_counts[name], estimated)
    result["d1"] = percent(d1_count + missing, evaluated)
    result["d1_sparse"] = percent(d1_count, estimated)
    result["avgerr"] = float(error.mean()) if estimated else 0.0
    result["rmse"] = float(math.sqrt((error ** 2).mean())) if estimated else 0.0
    return result


# ----------------------------------------------------------------------------------------------------------

def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", required=True, help="dataset root given to `linesight eval stereo --data`")
    parser.add_argument("--disparities", required=True,
                        help="folder given to --save-disparity (holds <set>/<scene>/<method>.pfm)")
    parser.add_argument("--json", required=True, help="the JSON report of `linesight eval stereo --json`")
    parser.add_argument("--tolerance", type=float, default=0.01,
                        help="largest accepted absolute difference (percentage points / px), default 0.01")
    parser.add_argument("--verbose", action="store_true", help="print every compared region")
    args = parser.parse_args(argv)

    try:
        with open(args.json) as f:
            report = json.load(f)
        entries = report["scenes"]
        scenes = find_scenes(args.data)
    except (OSError, ValueError, KeyError, TypeError, InputProblem) as e:
        print(f"verify_metrics: cannot read the input: {e}", file=sys.stderr)
        return 2

    max_diff = {key: 0.0 for key in VALUE_KEYS}
    worst_where = {key: "" for key in VALUE_KEYS}
    problems = []
    compared = 0
    skipped_noisy = 0
    cache = {}
    for entry in entries:
        try:
            set_name, scene_name, method = entry["set"], entry["scene"], entry["method"]
            regions = entry["regions"]
        except (KeyError, TypeError):
            problems.append(f"report entry without set/scene/method/regions: {json.dumps(entry)[:200]}")
            continue
        noise = entry.get("noise", "clean")
        where = f"{set_name}/{scene_name}/{method}" + ("" if noise == "clean" else f" (noise {noise})")
        key = (set_name, scene_name)
        if key not in scenes:
            problems.append(f"{where}: no such scene under {args.data}")
            continue
        # Clean runs: <set>/<scene>/<method>.pfm. A run on noisy input is checked when its map was saved as
        # <set>/<scene>/<noise>/<method>.pfm and skipped (and counted) otherwise.
        pfm_path = os.path.join(args.disparities, set_name, scene_name, method + ".pfm")
        if noise != "clean":
            pfm_path = os.path.join(args.disparities, set_name, scene_name, noise, method + ".pfm")
            if not os.path.isfile(pfm_path):
                skipped_noisy += 1
                continue
        try:
            if key not in cache:
                cache = {key: scenes[key]()}  # keep one scene in memory
            gt, masks = cache[key]
            disparity = read_pfm(pfm_path)
        except (OSError, ValueError, InputProblem) as e:
            problems.append(f"{where}: {e}")
            continue
        if disparity.ndim != 2 or disparity.shape != gt.shape:
            problems.append(f"{where}: disparity is {disparity.shape[::-1]} but ground truth {gt.shape[::-1]}")
            continue
        if set(regions) != set(masks):
            problems.append(f"{where}: report regions {sorted(regions)} but the data defines {sorted(masks)}")
        for region in sorted(set(regions) & set(masks)):
            ours = compute_metrics(disparity, gt, masks[region])
            theirs = regions[region]
            compared += 1
            for count_key in COUNT_KEYS:
                if theirs.get(count_key) != ours[count_key]:
                    problems.append(f"{where}/{region}: {count_key} {theirs.get(count_key)} != {ours[count_key]}")
            for value_key in VALUE_KEYS:
                if not isinstance(theirs.get(value_key), (int, float)):
                    problems.append(f"{where}/{region}: '{value_key}' missing or not a number")
                    continue
                diff = abs(float(theirs[value_key]) - ours[value_key])
                if diff > max_diff[value_key] or not worst_where[value_key]:
                    max_diff[value_key] = diff
                    worst_where[value_key] = f"{where}/{region}"
            if args.verbose:
                print(f"{where}/{region}: " +
                      " ".join(f"{k}={ours[k]:.4f}" for k in ["density", "bad_1", "bad_2", "d1", "avgerr"]))

    print(f"verify_metrics: {compared} region(s) of {len(entries)} report entr(y/ies) recomputed")
    if skipped_noisy:
        print(f"verify_metrics: {skipped_noisy} entr(y/ies) on noisy input skipped: no <set>/<scene>/<noise>/"
              "<method>.pfm saved for them")
    print(f"{'metric':<16} {'max |diff|':>12}  where")
    for key in VALUE_KEYS:
        print(f"{key:<16} {max_diff[key]:>12.3g}  {worst_where[key]}")
    over = [key for key in VALUE_KEYS if max_diff[key] > args.tolerance]
    for problem in problems:
        print(f"PROBLEM: {problem}", file=sys.stderr)
    if over:
        print(f"FAIL: {', '.join(over)} differ by more than {args.tolerance}", file=sys.stderr)
    if over or problems or compared == 0:
        if compared == 0:
            print("FAIL: nothing was compared", file=sys.stderr)
        return 1
    print(f"OK: every metric within {args.tolerance} and every pixel count equal")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
