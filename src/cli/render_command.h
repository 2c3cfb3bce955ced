// `firn render OUT_DIR [options]`: argument parsing and the command itself, kept out of main.cc
// because its options are many.
#pragma once

#include <firn/render.h>

#include <string>
#include <vector>

namespace firn::cli {

extern const char* const kRenderHelp;

struct RenderCommand {
    std::string outDir;
    RenderOptions options;              ///< all but `view` and `dimension`, set at run time
    std::vector<std::string> overrides; ///< render.<key>=<value>, applied to OUT_DIR/scene.toml
    bool help = false;
};

/// Parses the arguments after `firn render`; throws std::invalid_argument with a message.
RenderCommand parseRenderCommand(const std::vector<std::string>& args);

/// Reads [render] and the dimension from OUT_DIR/scene.toml with the command's overrides on top,
/// renders, and prints what was written. Returns the exit code.
int runRenderCommand(const RenderCommand& command);

} // namespace firn::cli
