"""Opens a USD cache written by `yarn_output::usda::Sequence` with Pixar's USD library
(the `usd-core` package) and checks it as a user's tool would load it.

    python3 usd_cache_check.py FILE FRAMES MESHES   (or through yarn_output::usda::check_with_usd)

Checks: the default prim `/Yarns` is a linear `BasisCurves` with a constant width; the stage's
frame range is 0 … FRAMES − 1 at a positive rate, in metres, with a Y or Z up axis; the points
have one time sample per frame, each as long as the sum of that frame's curve vertex counts;
each frame's authored extent holds its points and agrees with USD's own computed extent
(which includes the widths); `/Mesh0` … are MESHES meshes with one points sample per frame.
Prints one line per frame (time, points, extent) and exits non-zero on the first failure.
"""

import sys

from pxr import Usd, UsdGeom


def fail(message):
    print(f"usd_cache_check: {message}", file=sys.stderr)
    sys.exit(1)


def main():
    path, frames, meshes = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    stage = Usd.Stage.Open(path)
    if not stage:
        fail(f"{path}: USD could not open the layer")
    prim = stage.GetDefaultPrim()
    if not prim or str(prim.GetPath()) != "/Yarns" or not prim.IsA(UsdGeom.BasisCurves):
        fail(f"default prim is {prim}, expected the BasisCurves /Yarns")
    curves = UsdGeom.BasisCurves(prim)
    if curves.GetTypeAttr().Get() != "linear":
        fail(f"curve type {curves.GetTypeAttr().Get()}, expected linear")
    if stage.GetStartTimeCode() != 0 or stage.GetEndTimeCode() != frames - 1:
        fail(f"frame range {stage.GetStartTimeCode()}…{stage.GetEndTimeCode()}, expected 0…{frames - 1}")
    if not stage.GetTimeCodesPerSecond() > 0:
        fail(f"time codes per second {stage.GetTimeCodesPerSecond()}")
    if UsdGeom.GetStageMetersPerUnit(stage) != 1.0:
        fail(f"metersPerUnit {UsdGeom.GetStageMetersPerUnit(stage)}, expected 1")
    if UsdGeom.GetStageUpAxis(stage) not in (UsdGeom.Tokens.y, UsdGeom.Tokens.z):
        fail(f"up axis {UsdGeom.GetStageUpAxis(stage)}")
    widths = curves.GetWidthsAttr().Get()
    if widths is None or len(widths) != 1 or curves.GetWidthsInterpolation() != UsdGeom.Tokens.constant:
        fail(f"widths {widths} ({curves.GetWidthsInterpolation()}), expected one constant width")
    points = curves.GetPointsAttr()
    times = points.GetTimeSamples()
    if list(times) != [float(k) for k in range(frames)]:
        fail(f"points time samples {list(times)}, expected 0…{frames - 1}")
    for t in times:
        p = points.Get(t)
        counts = curves.GetCurveVertexCountsAttr().Get(t)
        if len(p) != sum(counts):
            fail(f"time {t}: {len(p)} points but the curve vertex counts sum to {sum(counts)}")
        lo, hi = curves.GetExtentAttr().Get(t)
        for q in p:
            if any(q[k] < lo[k] or q[k] > hi[k] for k in range(3)):
                fail(f"time {t}: point {q} outside the authored extent {lo} … {hi}")
        computed = UsdGeom.Boundable.ComputeExtentFromPlugins(curves, Usd.TimeCode(t))
        tolerance = 1e-5 * max(1.0, max(abs(c) for c in list(hi) + list(lo)))
        if computed is None or any(
            abs(computed[i][k] - e[k]) > tolerance for i, e in enumerate((lo, hi)) for k in range(3)
        ):
            fail(f"time {t}: authored extent {lo} … {hi}, USD computes {computed}")
        print(f"time {t:g}: {len(p)} points in {len(counts)} curves, extent {lo} … {hi}")
    for k in range(meshes):
        mesh = UsdGeom.Mesh(stage.GetPrimAtPath(f"/Mesh{k}"))
        if not mesh:
            fail(f"no mesh /Mesh{k}")
        n = len(mesh.GetPointsAttr().GetTimeSamples())
        if n != frames:
            fail(f"/Mesh{k}: {n} points samples, expected {frames}")
    extra = stage.GetPrimAtPath(f"/Mesh{meshes}")
    if extra:
        fail(f"unexpected mesh {extra.GetPath()}")


if __name__ == "__main__":
    main()
