// The scene of a finished run, as `firn report` needs it.
#pragma once

#include <firn/scene.h>

#include <string>

namespace firn::report {

/// The run's scene.toml without its [[terrain]], [[body]] and [[cut]] tables, nor the output
/// keys that need a terrain (output.rasters, output.path). The report needs the dimension, the
/// grid and the materials only, and a heightfield's DEM, a polygon body's file or a path line
/// need not be where scene.toml says: a run folder copied to another machine, or one written
/// before scene.toml held absolute paths, still gets its report. scene.toml is written by
/// toml++, which puts arrays of tables last, so the lines of the tables the report reads (and
/// what error messages say about them) do not move. Throws IoError (no file) or SceneError.
SceneDesc loadRunScene(const std::string& path);

} // namespace firn::report
