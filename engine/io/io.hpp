// engine/io: every file format perifx reads or writes, one file pair per format, reader and writer
// together. This header includes them all, for code that uses several.
//   atomic.*          write_atomic (temp file + fsync + rename), read_file, IoError / ReadError
//   vtk.*             VTK XML: one appended-data writer for particle VTU, surface VTP and tet VTU;
//                     the .pvd collection; VTU/PVD readers
//   ply.*             PLY points and surfaces (write), ASCII/binary PLY (read)
//   obj.*             OBJ surfaces + MTL (write), OBJ surfaces with crack groups (read)
//   stl.*, off.*      STL and OFF surfaces (read)
//   tetgen.*          TetGen .node/.ele (read), .smesh (write)
//   gmsh.*            Gmsh .msh 2.2/4.1 (read)
//   run_dir.*         a run's output directory read back (frames, times, surfaces, projectiles.csv)
//                     and its mesh.json (write + read), for `perifx render` and `perifx compare`
//   text.hpp, write_checks.hpp, triangle_surface.hpp, tet_file.hpp: shared by the above
#pragma once

#include "io/atomic.hpp"
#include "io/gmsh.hpp"
#include "io/obj.hpp"
#include "io/off.hpp"
#include "io/ply.hpp"
#include "io/run_dir.hpp"
#include "io/stl.hpp"
#include "io/tetgen.hpp"
#include "io/vtk.hpp"
