// Caches and reports (outputs.md). Output reads the world and never changes it: the solver hands
// plain arrays over, and only this module's translation units include OpenVDB's I/O.
#pragma once

#include <firn/errors.h>

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace firn {

/// Per-particle attributes of one frame, by outputs.md names. All arrays have the same length.
struct ParticleFrame {
    std::vector<std::array<float, 3>> P; ///< world-space position, m
    std::vector<std::array<float, 3>> v; ///< m/s
    std::vector<std::int32_t> material;
    std::vector<std::int32_t> failed;
    std::vector<float> eps_v, eta, p, q;
};

/// Sparse volume grids of one frame, laid out as VDB leaves: block b covers voxels
/// origin[b] + [0,8)^3 and its values sit at offset (x&7)<<6 | (y&7)<<3 | (z&7) of the block's
/// 512-entry slice (x-major, like openvdb::tree::LeafNode). In 2D only z = 0 is filled.
/// A voxel is active where density > 0.
struct VolumeFrame {
    double voxelSize = 0.05;
    std::vector<std::array<int, 3>> origin;     ///< voxel coordinates, multiples of 8
    std::vector<float> density;                 ///< kg/m^3, 512 per block
    std::vector<std::array<float, 3>> velocity; ///< m/s, 512 per block
    std::vector<float> failed;                  ///< failed mass fraction 0..1, 512 per block
    std::vector<float> eta;                     ///< mass-weighted mean eta, 512 per block
};

/// Metadata stored on every grid of a frame.
struct FrameInfo {
    int frame = 0;
    double time = 0.0; ///< simulated time, s
    double frameRate = 24.0;
    /// The simulation's local frame origin in scene coordinates (World::origin): added to the
    /// grids' transforms, so that positions read back are in the scene's coordinates.
    std::array<double, 3> origin = {0.0, 0.0, 0.0};
};

/// Writes `dir/particles.NNNN.vdb`: one PointDataGrid "points" with P, v, material, failed,
/// eps_v, eta, p, q (Blosc). Written to a temporary name in `dir`, then renamed. Throws IoError.
/// `particles` is taken by value and emptied as the grid takes its arrays in (pass a temporary,
/// or std::move, and it is not copied): a frame write then holds each particle value once.
void writeParticleCache(const std::string& dir, const FrameInfo& info, double voxelSize,
                        ParticleFrame particles);

/// Writes `dir/volume.NNNN.vdb` with the grids named in `grids` (of "density", "velocity",
/// "failed", "eta"), atomically as above. Throws IoError.
void writeVolumeCache(const std::string& dir, const FrameInfo& info, const VolumeFrame& volume,
                      const std::vector<std::string>& grids);

/// "particles.0007.vdb" style names.
std::string frameFileName(const std::string& stem, int frame);

/// Writes `text` to `path` atomically (temporary file in the same folder, then rename).
void writeFileAtomic(const std::string& path, const std::string& text);

/// A file written in pieces and put at its name only when whole, as writeFileAtomic does: for
/// outputs too large to build in memory first (a DEM's terrain mesh). Without commit() the
/// temporary file is removed and `path` left as it was. Errors are IoError with the path.
class AtomicFileWriter {
public:
    explicit AtomicFileWriter(const std::string& path);
    ~AtomicFileWriter();
    AtomicFileWriter(const AtomicFileWriter&) = delete;
    AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;
    /// Appends `text` (or `size` bytes at `data`) to the temporary file.
    void write(const std::string& text);
    void write(const char* data, std::size_t size);
    /// Overwrites bytes already written, from `offset` (a header field known only at the end).
    void writeAt(std::uint64_t offset, const std::string& bytes);
    /// Syncs and closes the temporary file, then renames it to `path`.
    void commit();

private:
    std::string mPath, mTmp;
    int mFd = -1;
};

/// Creates a folder and its parents; throws IoError with the path on failure.
void makeDirectories(const std::string& path);

/// metrics.csv: a header from `columns`, then one row per append, flushed at once so that a
/// stopped run keeps its rows. Empty optional cells are written as nothing between commas.
class MetricsWriter {
public:
    MetricsWriter(const std::string& path, std::vector<std::string> columns);
    /// Continues the file of a resumed run: keeps its header (which must list `columns`) and
    /// its first `keepRows` rows, drops the rows after them (frames past the checkpoint, which
    /// the resumed run writes again) and appends from there. Throws IoError.
    MetricsWriter(const std::string& path, std::vector<std::string> columns, std::size_t keepRows);
    ~MetricsWriter();
    MetricsWriter(const MetricsWriter&) = delete;
    MetricsWriter& operator=(const MetricsWriter&) = delete;
    /// One value per column, already formatted (use formatNumber); "" for an empty cell.
    void appendRow(const std::vector<std::string>& cells);

private:
    std::string mPath;
    std::vector<std::string> mColumns;
    void* mFile = nullptr; // FILE*
};

/// Shortest round-trip text for a double ("0.1", "1e-06", "nan" written as "").
std::string formatNumber(double value);

/// A flat JSON object writer for summary.json: keys in insertion order.
class JsonObject {
public:
    void set(const std::string& key, double value); ///< non-finite written as null
    void set(const std::string& key, long long value);
    void set(const std::string& key, int value) { set(key, static_cast<long long>(value)); }
    void set(const std::string& key, const std::string& value);
    void set(const std::string& key, const char* value) { set(key, std::string(value)); }
    void setBool(const std::string& key, bool value);
    void setNull(const std::string& key);
    /// An array of numbers on one line (non-finite ones as null).
    void set(const std::string& key, const std::vector<double>& values);
    /// An array of objects, one object per line.
    void set(const std::string& key, const std::vector<JsonObject>& objects);
    std::string str() const;
    /// The object on one line, without a trailing newline.
    std::string inlineStr() const;

private:
    std::vector<std::pair<std::string, std::string>> mItems; // key, encoded value
};

} // namespace firn
