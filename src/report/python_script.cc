#include "report/python_script.h"

#include <firn/errors.h>

#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>

extern char** environ;

namespace firn::report {

namespace {
constexpr const char* kPython = "/usr/bin/python3";
} // namespace

std::string renderScriptPath(const std::string& name) {
    const char* fromEnv = std::getenv("FIRN_RENDER_SCRIPTS");
    const std::string folder = fromEnv && *fromEnv ? fromEnv : FIRN_RENDER_SCRIPTS;
    const std::string path = folder + "/" + name;
    std::error_code error;
    if (!std::filesystem::is_regular_file(path, error)) {
        throw IoError("chart script not found: " + path + " (set FIRN_RENDER_SCRIPTS to the " +
                      "folder that holds " + name + ")");
    }
    return path;
}

void runPythonScript(const std::string& script, const std::vector<std::string>& args) {
    std::vector<std::string> all = {kPython, script};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    const int spawned = posix_spawn(&pid, kPython, nullptr, nullptr, argv.data(), environ);
    if (spawned != 0) {
        throw IoError(std::string("cannot start ") + kPython + ": " + std::strerror(spawned) +
                      " (the charts need Debian's python3 with python3-matplotlib)");
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0) {
        if (errno != EINTR)
            throw IoError(std::string("waiting for ") + script + ": " + std::strerror(errno));
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return;
    const std::string how = WIFEXITED(status) ? "exit status " + std::to_string(WEXITSTATUS(status))
                                              : "signal " + std::to_string(WTERMSIG(status));
    throw IoError(script + " failed with " + how + " (its messages are above)");
}

} // namespace firn::report
