// One exception hierarchy (style.md): main catches these and maps them to exit codes
// 1 (scene or usage), 2 (simulation failed), 3 (I/O).
#pragma once

#include <stdexcept>
#include <string>

namespace firn {

/// Where something came from in a scene file. line/column are 1-based; 0 means unknown.
struct SourceLoc {
    std::string file;
    int line = 0;
    int column = 0;
};

/// "file:line:col" (parts that are unknown are left out).
std::string formatLoc(const SourceLoc& loc);

class FirnError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// A scene or usage error; what() reads "file:line:col: error: <key>: <message>".
class SceneError : public FirnError {
public:
    SceneError(const SourceLoc& loc, const std::string& key, const std::string& message);
    const SourceLoc& loc() const { return mLoc; }
    const std::string& key() const { return mKey; }

private:
    SourceLoc mLoc;
    std::string mKey;
};

/// The simulation could not go on (non-finite state, energy blow-up).
class SimulationError : public FirnError {
public:
    using FirnError::FirnError;
};

/// A file could not be read or written.
class IoError : public FirnError {
public:
    using FirnError::FirnError;
};

} // namespace firn
