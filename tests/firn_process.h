// Spawning the real firn binary from tests: its stdout and stderr go to files, and the tests
// wait for it with a timeout (cli_test, checkpoint_test).
#pragma once

#include "test_util.h"

#include <firn_test_paths.h>

#include <catch2/catch.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace firn::test {

inline int count(const std::string& text, char c) {
    return int(std::count(text.begin(), text.end(), c));
}

inline std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

inline void writeText(const std::string& path, const std::string& text) {
    std::ofstream(path, std::ios::binary) << text;
}

/// Where a spawned firn writes its stdout and stderr.
struct Capture {
    std::string out, err;
};

inline Capture captureFiles(const std::string& dir) {
    static int counter = 0;
    const std::string stem = dir + "/firn-" + std::to_string(counter++);
    return {stem + ".stdout", stem + ".stderr"};
}

/// Starts FIRN_BINARY with `args`, stdin from /dev/null, stdout and stderr into `cap`, SIGINT and
/// SIGTERM at their default and unblocked whatever the test runner does with them.
inline pid_t spawnProgram(std::vector<std::string> all, const Capture& cap) {
    std::vector<char*> argv;
    for (std::string& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);

    posix_spawn_file_actions_t files;
    posix_spawn_file_actions_init(&files);
    posix_spawn_file_actions_addopen(&files, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&files, 1, cap.out.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                     0644);
    posix_spawn_file_actions_addopen(&files, 2, cap.err.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                     0644);
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    sigset_t none, stopSignals;
    sigemptyset(&none);
    sigemptyset(&stopSignals);
    sigaddset(&stopSignals, SIGINT);
    sigaddset(&stopSignals, SIGTERM);
    posix_spawnattr_setsigmask(&attr, &none);
    posix_spawnattr_setsigdefault(&attr, &stopSignals);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);

    pid_t pid = -1;
    const int rc = posix_spawn(&pid, argv[0], &files, &attr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&files);
    posix_spawnattr_destroy(&attr);
    INFO("posix_spawn " << all[0]);
    REQUIRE(rc == 0);
    return pid;
}

inline pid_t spawnFirn(const std::vector<std::string>& args, const Capture& cap) {
    std::vector<std::string> all = {FIRN_BINARY};
    all.insert(all.end(), args.begin(), args.end());
    return spawnProgram(all, cap);
}

/// The exit code of `pid`; 1000 + signal when a signal killed it, -1 (and the process killed)
/// when it has not ended within `timeoutSeconds`.
inline int waitExit(pid_t pid, double timeoutSeconds) {
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(timeoutSeconds);
    int status = 0;
    while (waitpid(pid, &status, WNOHANG) == 0) {
        if (std::chrono::steady_clock::now() > deadline) {
            kill(pid, SIGKILL);
            waitpid(pid, &status, 0);
            return -1;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    if (WIFEXITED(status)) return WEXITSTATUS(status);
    if (WIFSIGNALED(status)) return 1000 + WTERMSIG(status);
    return -2;
}

struct Outcome {
    int code = -1;
    std::string out, err;
};

/// Runs firn to the end (at most a minute) and returns its exit code and output.
inline Outcome runFirn(const std::vector<std::string>& args, const TempDir& dir) {
    const Capture cap = captureFiles(dir.path());
    Outcome o;
    o.code = waitExit(spawnFirn(args, cap), 60.0);
    o.out = slurp(cap.out);
    o.err = slurp(cap.err);
    return o;
}

/// Runs `command` with /bin/sh (for ulimit and the like; $FIRN is the binary).
inline Outcome runShell(const std::string& command, const TempDir& dir) {
    const Capture cap = captureFiles(dir.path());
    Outcome o;
    o.code =
        waitExit(spawnProgram({"/bin/sh", "-c", "FIRN='" FIRN_BINARY "'; " + command}, cap), 60.0);
    o.out = slurp(cap.out);
    o.err = slurp(cap.err);
    return o;
}

// Waits (at most `timeoutSeconds`) until `path` holds at least `lines` complete lines.
inline bool waitForLines(const std::string& path, int lines, double timeoutSeconds) {
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(timeoutSeconds);
    while (std::chrono::steady_clock::now() < deadline) {
        if (count(slurp(path), '\n') >= lines) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
}

} // namespace firn::test
