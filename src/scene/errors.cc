#include <firn/errors.h>

namespace firn {

std::string formatLoc(const SourceLoc& loc) {
    std::string out = loc.file.empty() ? std::string("<scene>") : loc.file;
    if (loc.line > 0) {
        out += ":" + std::to_string(loc.line);
        if (loc.column > 0) out += ":" + std::to_string(loc.column);
    }
    return out;
}

static std::string sceneMessage(const SourceLoc& loc, const std::string& key,
                                const std::string& message) {
    std::string out = formatLoc(loc) + ": error: ";
    if (!key.empty()) out += key + ": ";
    return out + message;
}

SceneError::SceneError(const SourceLoc& loc, const std::string& key, const std::string& message)
    : FirnError(sceneMessage(loc, key, message))
    , mLoc(loc)
    , mKey(key) {}

} // namespace firn
