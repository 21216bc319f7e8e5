// The `perifx render` command line (parsing, progress display, exit codes), kept here so the CLI's
// main only dispatches to it.
#pragma once

namespace perifx::render {

inline constexpr const char* kRenderUsage =
    "  render RUN_DIR [--out DIR] [--width W] [--height H] [--color-by damage|material|none]\n"
    "         [--frames A:B] [--mp4] [--backend povray|builtin] [--scene SCENE.json]\n"
    "         [--projectile-radius R] [--particle-scale S] [--draw auto|particles|surface]\n"
    "         [--threads N] [--view X,Y,Z] [--fit-frames A:B] [--zoom Z] [--cut NX,NY,NZ,D] [--quiet]\n"
    "                      PNG frames (RUN_DIR/render/frame.NNNN.png) and with --mp4 a movie (ffmpeg);\n"
    "                      --draw: the embedded-mesh surface (crack faces orange) or the particles;\n"
    "                      --view: direction from the subject to the camera (default 0.75,0.55,1.3);\n"
    "                      --fit-frames: frames the camera is framed on; --zoom Z > 1: closer;\n"
    "                      --cut: leave out what lies where n·x > D (a cut-away view of the inside)\n";

// argv[1] is "render". Returns the process exit code (0 ok, 1 usage, 2 unreadable run directory,
// 3 output error, 5 backend or internal error).
int render_command(int argc, char** argv);

}  // namespace perifx::render
