// Reports and file plumbing (outputs.md): metrics.csv, summary.json, atomic writes, folders.
// Kept apart from vdb_cache.cc so that none of this pays for OpenVDB's headers.
#include <firn/io.h>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string_view>
#include <system_error>

namespace firn {
namespace {

namespace fs = std::filesystem;

IoError writeError(const std::string& path, int errnum) {
    return IoError("cannot write " + path + ": " +
                   (errnum != 0 ? std::strerror(errnum) : "write failed"));
}

/// `dir/.name.tmp` for `dir/name`: the same folder, so that the rename cannot cross file
/// systems, and a dot name, so that tools globbing for frames skip it.
std::string tempPathFor(const std::string& path) {
    const fs::path p(path);
    return (p.parent_path() / ("." + p.filename().string() + ".tmp")).string();
}

/// write(2), or pwrite(2) at `offset` where it is not negative, may write less than asked
/// (signals, pipes); loop until all `left` bytes are out.
void writeAll(int fd, const char* data, size_t left, const std::string& path, off_t offset = -1) {
    while (left > 0) {
        const ssize_t n = offset < 0 ? ::write(fd, data, left) : ::pwrite(fd, data, left, offset);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw writeError(path, errno);
        data += n;
        left -= size_t(n);
        if (offset >= 0) offset += off_t(n);
    }
}

/// RFC 4180 quoting, needed only if a cell ever holds a comma, a quote or a line break.
std::string csvField(const std::string& cell) {
    if (cell.find_first_of(",\"\r\n") == std::string::npos) return cell;
    std::string out = "\"";
    for (char c : cell) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

std::string csvLine(const std::vector<std::string>& cells) {
    std::string line;
    for (size_t i = 0; i < cells.size(); ++i) {
        if (i > 0) line += ',';
        line += csvField(cells[i]);
    }
    return line + '\n';
}

std::string jsonString(const std::string& s) {
    // JSON's two-character escapes (RFC 8259, section 7); other control characters as \u00XX.
    constexpr std::string_view kRaw = "\"\\\b\f\n\r\t", kEscaped = "\"\\bfnrt";
    std::string out = "\"";
    for (const char c : s) {
        const size_t k = kRaw.find(c);
        if (k != std::string_view::npos) {
            out += '\\';
            out += kEscaped[k];
        } else if (static_cast<unsigned char>(c) < 0x20) {
            char escaped[8];
            std::snprintf(escaped, sizeof escaped, "\\u%04x", unsigned(c));
            out += escaped;
        } else {
            out += c; // UTF-8 passes through: JSON text is UTF-8
        }
    }
    return out + '"';
}

/// Sets `key` to an encoded value; a key set twice keeps its first place.
void upsert(std::vector<std::pair<std::string, std::string>>& items, const std::string& key,
            std::string encoded) {
    for (auto& item : items) {
        if (item.first == key) {
            item.second = std::move(encoded);
            return;
        }
    }
    items.emplace_back(key, std::move(encoded));
}

} // namespace

std::string frameFileName(const std::string& stem, int frame) {
    if (frame < 0) throw std::invalid_argument("negative frame number " + std::to_string(frame));
    char digits[16];
    std::snprintf(digits, sizeof digits, "%04d", frame);
    return stem + "." + digits + ".vdb";
}

void writeFileAtomic(const std::string& path, const std::string& text) {
    AtomicFileWriter file(path);
    file.write(text);
    file.commit();
}

AtomicFileWriter::AtomicFileWriter(const std::string& path)
    : mPath(path)
    , mTmp(tempPathFor(path))
    , mFd(::open(mTmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644)) {
    if (mFd < 0) throw writeError(mPath, errno);
}

AtomicFileWriter::~AtomicFileWriter() {
    if (mFd < 0) return;
    ::close(mFd);
    std::remove(mTmp.c_str());
}

void AtomicFileWriter::write(const std::string& text) {
    writeAll(mFd, text.data(), text.size(), mPath);
}

void AtomicFileWriter::write(const char* data, std::size_t size) {
    writeAll(mFd, data, size, mPath);
}

void AtomicFileWriter::writeAt(std::uint64_t offset, const std::string& bytes) {
    writeAll(mFd, bytes.data(), bytes.size(), mPath, off_t(offset));
}

void AtomicFileWriter::commit() {
    // The sync comes before the rename, so that a power cut cannot leave the final name on an
    // empty file.
    const int fd = mFd;
    mFd = -1;
    const bool synced = ::fsync(fd) == 0;
    const int syncError = errno;
    const bool closed = ::close(fd) == 0;
    const int closeError = errno;
    if (!synced || !closed || std::rename(mTmp.c_str(), mPath.c_str()) != 0) {
        const int error = !synced ? syncError : !closed ? closeError : errno;
        std::remove(mTmp.c_str());
        throw writeError(mPath, error);
    }
}

void makeDirectories(const std::string& path) {
    if (path.empty()) return; // the current folder
    std::error_code ec;
    fs::create_directories(path, ec);
    // create_directories is content with an existing path, even when that is a file.
    if (!ec && !fs::is_directory(path, ec) && !ec) {
        ec = std::make_error_code(std::errc::not_a_directory);
    }
    if (ec) throw IoError("cannot create directory " + path + ": " + ec.message());
}

////////////////////////////////////////

MetricsWriter::MetricsWriter(const std::string& path, std::vector<std::string> columns)
    : mPath(path)
    , mColumns(std::move(columns)) {
    std::FILE* file = std::fopen(path.c_str(), "w");
    if (!file) throw writeError(path, errno);
    mFile = file;
    try {
        appendRow(mColumns); // the header, on disk before the first frame
    } catch (...) {
        std::fclose(file);
        mFile = nullptr;
        throw;
    }
}

MetricsWriter::MetricsWriter(const std::string& path, std::vector<std::string> columns,
                             std::size_t keepRows)
    : mPath(path)
    , mColumns(std::move(columns)) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("cannot read " + path + " to continue it");
    std::string line, kept;
    std::size_t rows = 0;
    if (!std::getline(in, line) || line + "\n" != csvLine(mColumns))
        throw IoError(path + " does not have this Firn's columns; cannot continue it");
    kept = line + "\n";
    while (rows < keepRows && std::getline(in, line)) kept += line + "\n", ++rows;
    if (rows < keepRows)
        throw IoError(path + " has " + std::to_string(rows) + " rows, the checkpoint needs " +
                      std::to_string(keepRows));
    in.close();
    writeFileAtomic(path, kept);
    std::FILE* file = std::fopen(path.c_str(), "a");
    if (!file) throw writeError(path, errno);
    mFile = file;
}

MetricsWriter::~MetricsWriter() {
    if (mFile) std::fclose(static_cast<std::FILE*>(mFile)); // rows are flushed already
}

void MetricsWriter::appendRow(const std::vector<std::string>& cells) {
    if (cells.size() != mColumns.size()) {
        throw std::logic_error("metrics row has " + std::to_string(cells.size()) + " cells for " +
                               std::to_string(mColumns.size()) + " columns");
    }
    auto* file = static_cast<std::FILE*>(mFile);
    // Flushed row by row: a run stopped by a signal or a crash keeps every finished frame.
    const long before = std::ftell(file);
    errno = 0;
    if (std::fputs(csvLine(cells).c_str(), file) < 0 || std::fflush(file) != 0) {
        const int errnum = errno;
        // A full disk may have taken part of the row: cut it off, so that every row on disk
        // is whole (a resumed run continues the file).
        std::clearerr(file);
        if (before >= 0 && ::ftruncate(fileno(file), before) == 0)
            std::fseek(file, before, SEEK_SET);
        throw writeError(mPath, errnum);
    }
}

////////////////////////////////////////

std::string formatNumber(double value) {
    if (!std::isfinite(value)) return "";
    // Whole numbers (frames, steps, counts) read better as integers: "1000000", not "1e+06".
    // "%.0f" keeps the sign of -0.
    char text[40];
    if (value == std::trunc(value) && std::fabs(value) < 1e15) {
        std::snprintf(text, sizeof text, "%.0f", value);
        return text;
    }
    // The fewest significant digits that read back as the same double; 17 always do.
    for (int digits = 6; digits <= 17; ++digits) {
        std::snprintf(text, sizeof text, "%.*g", digits, value);
        if (std::strtod(text, nullptr) == value) break;
    }
    return text;
}

void JsonObject::set(const std::string& key, double value) {
    upsert(mItems, key, std::isfinite(value) ? formatNumber(value) : "null");
}

void JsonObject::set(const std::string& key, const std::vector<double>& values) {
    std::string out = "[";
    for (std::size_t i = 0; i < values.size(); ++i)
        out += (i ? ", " : "") + (std::isfinite(values[i]) ? formatNumber(values[i]) : "null");
    upsert(mItems, key, out + "]");
}

void JsonObject::set(const std::string& key, long long value) {
    upsert(mItems, key, std::to_string(value));
}

void JsonObject::set(const std::string& key, const std::string& value) {
    upsert(mItems, key, jsonString(value));
}

void JsonObject::setBool(const std::string& key, bool value) {
    upsert(mItems, key, value ? "true" : "false");
}

void JsonObject::setNull(const std::string& key) {
    upsert(mItems, key, "null");
}

void JsonObject::set(const std::string& key, const std::vector<JsonObject>& objects) {
    if (objects.empty()) return upsert(mItems, key, "[]");
    std::string out = "[\n";
    for (std::size_t i = 0; i < objects.size(); ++i)
        out += "    " + objects[i].inlineStr() + (i + 1 < objects.size() ? ",\n" : "\n");
    upsert(mItems, key, out + "  ]");
}

std::string JsonObject::inlineStr() const {
    std::string out = "{";
    for (std::size_t i = 0; i < mItems.size(); ++i)
        out += (i ? ", " : "") + jsonString(mItems[i].first) + ": " + mItems[i].second;
    return out + "}";
}

std::string JsonObject::str() const {
    if (mItems.empty()) return "{}\n";
    std::string out = "{\n";
    for (size_t i = 0; i < mItems.size(); ++i) {
        out += "  " + jsonString(mItems[i].first) + ": " + mItems[i].second;
        out += i + 1 < mItems.size() ? ",\n" : "\n";
    }
    return out + "}\n";
}

} // namespace firn
