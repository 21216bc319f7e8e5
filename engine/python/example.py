import numpy as np, perifx                          # PYTHONPATH=build/python

world = perifx.World("tests/engine/data/resume_wall.json")  # or perifx.World({...scene as a dict...})
print(world.particle_count, "particles,", world.bond_count, "bonds, dt", world.dt)
world.step(100)                                     # a steel ball tears a ductile wall
damage = world.field("damage")                      # read-only NumPy view, no copy
print(f"t={world.time:.4f} s  mean damage {damage.mean():.3f}  pieces {world.fragment_count}")
s = world.surface()                                 # arrays: vertices, triangles, crack, fragment
print(len(s["triangles"]), "triangles,", int(s["crack"].sum()), "on cracks; y range", np.ptp(world.positions()[:, 1]))
summary = perifx.run("tests/engine/data/resume_wall.json", out="/tmp/perifx_example", overwrite=True,
                     progress=lambda p: print(f"frame {p['frame']}/{p['frames']}", end="\r"))
print("\nwrote", summary["frames"], "frames to", summary["output_directory"])
