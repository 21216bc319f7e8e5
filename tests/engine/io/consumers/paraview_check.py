# The ParaView column of the README's attribute table, checked with pvpython:
#   pvpython paraview_check.py RUN_DIR
# Opens one frame's surface.NNNN.vtp, surface.NNNN.ply and surface.NNNN.obj (and animation.obj) the
# way File > Open does (OpenDataFile), lists the point and cell arrays each reader gives, and compares
# the perifx attributes (piece id, crack flag, velocity, normal) with what the README states.
# Exits 1 when ParaView keeps an attribute the table says it drops or drops one it says it keeps.
import os
import sys

from paraview import servermanager
from paraview.simple import OpenDataFile

run = sys.argv[1]
frame = max(int(f.split(".")[1]) for f in os.listdir(run) if f.startswith("surface.") and f.endswith(".vtp"))

# attribute -> the array names that carry it in ParaView
CARRIERS = {
    "piece": ("piece", "fragment"),
    "crack": ("crack", "MaterialIds"),  # OBJ: the material (surface / crack) per cell
    "velocity": ("velocity", "vx"),
    "normal": ("normal", "Normals"),
    "groups": ("GroupIds",),
}
# What the README table says ParaView keeps, per file.
EXPECTED = {
    "surface.vtp": {"piece", "crack", "velocity", "normal"},
    "surface.ply": {"normal"},
    "surface.obj": {"groups", "crack"},
}

files = {
    "surface.vtp": f"surface.{frame:04d}.vtp",
    "surface.ply": f"surface.{frame:04d}.ply",
    "surface.obj": f"surface.{frame:04d}.obj",
}
bad = 0
for label, name in files.items():
    reader = OpenDataFile(os.path.join(run, name))
    reader.UpdatePipeline()
    data = servermanager.Fetch(reader)
    if data.IsA("vtkMultiBlockDataSet"):
        data = data.GetBlock(0)
    arrays = set()
    for kind, attrs in (("point", data.GetPointData()), ("cell", data.GetCellData())):
        for k in range(attrs.GetNumberOfArrays()):
            arrays.add(attrs.GetArrayName(k))
    kept = {a for a, names in CARRIERS.items() if any(n in arrays for n in names)}
    print(f"{label}: reader {reader.GetXMLName()}, {data.GetNumberOfPoints()} points, {data.GetNumberOfCells()} cells, "
          f"arrays {sorted(arrays)}; perifx attributes kept: {sorted(kept)}")
    if kept != EXPECTED[label]:
        print(f"  MISMATCH: the README says {sorted(EXPECTED[label])}")
        bad += 1
print("paraview check:", "FAILED" if bad else "passed")
sys.exit(1 if bad else 0)
