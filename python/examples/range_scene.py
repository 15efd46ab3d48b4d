"""The obstacles on the rendered power line, typed and ranged along the conductor, against the truth.

    PYTHONPATH=build/python python3 python/examples/range_scene.py
"""
import linesight

scene = linesight.render_scene(seed=3)  # raw BGR pair, true calibration, exact truth
pipeline = linesight.RangingPipeline(scene["calibration"], method="isgm", line=True)
result = pipeline.range(scene["left"], scene["right"])

print(f"{'type':<10} {'along the line':>16} {'straight':>16}   truth: along, straight")
for found in result["line"]["obstacles"]:
    truth = min(scene["obstacles"], key=lambda t: abs(t["distance_m"] - found["distance_m"]))
    print(f"{found['type']:<10} {found['arc_m']:6.3f} ± {found['arc_sigma_m']:.3f} m "
          f"{found['distance_m']:6.3f} ± {found['sigma_m']:.3f} m   "
          f"{truth['type']} {truth['near_arc_m']:.3f} m, {truth['distance_m']:.3f} m")
