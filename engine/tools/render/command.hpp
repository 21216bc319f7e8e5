// `perifx render` once the command line is parsed (engine/cli/main.cpp does the parsing): progress
// display, the summary, and the mapping of errors to exit codes.
#pragma once
#include "tools/render/render_run.hpp"

namespace perifx::render {

// Returns the process exit code (0 ok, 1 usage, 2 unreadable run directory, 3 output error,
// 5 backend or internal error).
int render_command(RenderOptions options, bool quiet);

}  // namespace perifx::render
