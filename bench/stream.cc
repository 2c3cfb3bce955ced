// firn_stream: this machine's memory bandwidth, as STREAM's triad and copy measure it (McCalpin,
// "Memory Bandwidth and Machine Balance", 1995), on TBB threads as Firn's kernels run: the
// ceiling a bandwidth-bound kernel meets when it scales past the cores measured here. Best of 10
// passes over three arrays of 64 MB each, far beyond the caches.
//
//   build/firn_stream [--threads N]
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace {

template <typename Body> double bestSeconds(int passes, Body&& body) {
    double best = 1e30;
    for (int p = 0; p < passes; ++p) {
        const auto t0 = std::chrono::steady_clock::now();
        body();
        best = std::min(
            best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    return best;
}

} // namespace

int main(int argc, char** argv) {
    int threads = tbb::info::default_concurrency();
    for (int i = 1; i + 1 < argc; ++i)
        if (std::strcmp(argv[i], "--threads") == 0) threads = std::atoi(argv[i + 1]);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const std::size_t n = std::size_t(16) << 20; // floats: 64 MB an array
    std::vector<float> a(n, 1.f), b(n, 2.f), c(n, 3.f);
    const tbb::blocked_range<std::size_t> all(0, n, std::size_t(1) << 16);
    const double triad = bestSeconds(10, [&] {
        tbb::parallel_for(all, [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) a[i] = b[i] + 1.5f * c[i];
        });
    });
    const double copy = bestSeconds(10, [&] {
        tbb::parallel_for(all, [&](const auto& r) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) b[i] = a[i];
        });
    });
    const double bytes = double(n) * sizeof(float);
    std::printf("threads %d: triad %.1f GB/s, copy %.1f GB/s\n", threads, 3.0 * bytes / triad / 1e9,
                2.0 * bytes / copy / 1e9);
    return 0;
}
