// Plain binary (de)serialisation for checkpoints: values and arrays of trivially copyable types
// in native byte order (a checkpoint is read back by the same build on the same kind of
// machine; its header records the format and Firn version). Reads are bounds-checked.
#pragma once

#include <cstdint>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace firn {

/// 64-bit FNV-1a of `size` bytes (Fowler, Noll, Vo), continuing from `h`: checkpoint
/// checksums and content UUIDs of .vdb files. Not cryptographic; it detects damage.
inline std::uint64_t fnv1a64(const char* data, std::size_t size,
                             std::uint64_t h = 0xcbf29ce484222325ull) {
    for (std::size_t i = 0; i < size; ++i) {
        h ^= static_cast<unsigned char>(data[i]);
        h *= 0x100000001b3ull;
    }
    return h;
}

/// Types whose bytes are their value: trivially copyable ones, and fixed-size Eigen vectors and
/// matrices (plain arrays of scalars that declare their own copy constructor).
template <typename T>
constexpr bool kPlainBytes = std::is_trivially_copyable_v<T> ||
                             (std::is_standard_layout_v<T> && std::is_trivially_destructible_v<T>);

class ByteWriter {
public:
    /// Where a streaming writer's bytes go, in the order written.
    using Sink = std::function<void(const char* data, std::size_t size)>;
    /// Keeps the bytes (bytes()).
    ByteWriter() = default;
    /// Hands the bytes to `sink` in pieces of about kChunk bytes, a large array directly from
    /// its own memory, instead of keeping them: a checkpoint of a large run is written without
    /// an image of it in memory. flush() hands over the last piece.
    explicit ByteWriter(Sink sink)
        : mSink(std::move(sink)) {}
    template <typename T> void value(const T& v) {
        static_assert(kPlainBytes<T>);
        append(reinterpret_cast<const char*>(&v), sizeof(T));
    }
    template <typename T> void array(const std::vector<T>& v) {
        static_assert(kPlainBytes<T>);
        value(std::uint64_t(v.size()));
        append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    }
    void string(const std::string& s) {
        value(std::uint64_t(s.size()));
        append(s.data(), s.size());
    }
    void flush() {
        if (!mSink || mBytes.empty()) return;
        mSink(mBytes.data(), mBytes.size());
        mBytes.clear();
    }
    /// Bytes written so far, kept or handed over.
    std::uint64_t size() const { return mSize; }
    /// The bytes kept (a streaming writer's: those not handed over yet).
    const std::string& bytes() const { return mBytes; }

private:
    static constexpr std::size_t kChunk = std::size_t(1) << 20;
    void append(const char* data, std::size_t size) {
        mSize += size;
        if (mSink && size >= kChunk) {
            flush();
            mSink(data, size);
            return;
        }
        mBytes.append(data, size);
        if (mSink && mBytes.size() >= kChunk) flush();
    }

    Sink mSink;
    std::string mBytes;
    std::uint64_t mSize = 0;
};

/// Thrown when a read runs past the end: the data is truncated or not what the reader expects.
class ByteReadError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

class ByteReader {
public:
    ByteReader(const char* data, std::size_t size)
        : mData(data)
        , mSize(size) {}
    template <typename T> void value(T& v) {
        static_assert(kPlainBytes<T>);
        std::memcpy(static_cast<void*>(&v), take(sizeof(T)), sizeof(T));
    }
    template <typename T> T value() {
        T v{};
        value(v);
        return v;
    }
    template <typename T> void array(std::vector<T>& v) {
        static_assert(kPlainBytes<T>);
        const std::uint64_t n = value<std::uint64_t>();
        if (n > (mSize - mOffset) / (sizeof(T) ? sizeof(T) : 1))
            throw ByteReadError("array of " + std::to_string(n) + " items runs past the end");
        v.resize(n);
        if (n) std::memcpy(static_cast<void*>(v.data()), take(n * sizeof(T)), n * sizeof(T));
    }
    void string(std::string& s) {
        const std::uint64_t n = value<std::uint64_t>();
        if (n > mSize - mOffset) throw ByteReadError("string runs past the end");
        s.assign(take(n), n);
    }
    std::size_t remaining() const { return mSize - mOffset; }

private:
    const char* take(std::size_t n) {
        if (n > mSize - mOffset) throw ByteReadError("read past the end");
        const char* p = mData + mOffset;
        mOffset += n;
        return p;
    }
    const char* mData;
    std::size_t mSize;
    std::size_t mOffset = 0;
};

} // namespace firn
