#include <firn/dem.h>
#include <firn/errors.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <istream>
#include <limits>
#include <map>
#include <sstream>

namespace firn {

namespace {

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

// Far outside any real DEM, these keep the collider's float heights, slopes and normals finite.
constexpr double kMinCell = 1e-6, kMaxCell = 1e6; // m
constexpr double kMaxHeight = 1e6;                // |height|, m
constexpr double kMaxCoordinate = 1e9;            // |centre of the lower-left cell|, m

// A number as messages show it ("1e+06", "0.5").
std::string formatNumber(double value) {
    std::ostringstream out;
    out << value;
    return out.str();
}

[[noreturn]] void fail(const std::string& path, int line, const std::string& what) {
    throw SceneError(SourceLoc{path, line, 0}, "heightfield", what);
}

} // namespace

Heightfield Heightfield::readEsriAscii(const std::string& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) fail(path, 0, "cannot open the DEM file");
    const std::streamoff size = in.tellg();
    in.seekg(0);
    return parse(in, std::size_t(std::max<std::streamoff>(size, 0)), path);
}

Heightfield Heightfield::parseEsriAscii(const std::string& text, const std::string& path) {
    std::istringstream in(text);
    return parse(in, text.size(), path);
}

Heightfield Heightfield::parse(std::istream& in, std::size_t size, const std::string& path) {
    std::map<std::string, double> header;
    std::string lineText;
    int line = 0;
    std::streampos dataStart = in.tellg();
    while (std::getline(in, lineText)) {
        ++line;
        std::istringstream words(lineText);
        std::string key;
        double value = 0.0;
        if (!(words >> key) || std::isdigit(static_cast<unsigned char>(key[0])) || key[0] == '-' ||
            key[0] == '+' || key[0] == '.') {
            --line;
            break; // the first data row
        }
        if (!(words >> value)) fail(path, line, "header key '" + key + "' needs a number");
        header[lower(key)] = value;
        dataStart = in.tellg();
    }
    for (const char* key : {"ncols", "nrows", "cellsize"})
        if (!header.count(key)) fail(path, line, std::string("missing header key '") + key + "'");
    const bool xCentre = header.count("xllcenter"), zCentre = header.count("yllcenter");
    if (!xCentre && !header.count("xllcorner")) fail(path, line, "missing 'xllcorner'");
    if (!zCentre && !header.count("yllcorner")) fail(path, line, "missing 'yllcorner'");

    // Checked as doubles before any conversion (a count beyond int is undefined behaviour), and
    // bounded so that the collider's float heights and slopes stay finite (fuzz/README.md).
    const double columns = header["ncols"], rows = header["nrows"], cell = header["cellsize"];
    const double maxCount = std::numeric_limits<int>::max();
    if (!(columns >= 2 && columns <= maxCount && rows >= 2 && rows <= maxCount && cell > 0.0))
        fail(path, 1, "needs ncols >= 2, nrows >= 2 and cellsize > 0");
    if (columns != std::floor(columns) || rows != std::floor(rows))
        fail(path, 1, "ncols and nrows must be whole numbers");
    if (!(cell >= kMinCell && cell <= kMaxCell))
        fail(path, 1,
             "cellsize must be in [" + formatNumber(kMinCell) + ", " + formatNumber(kMaxCell) +
                 "] m");
    Heightfield h;
    h.mColumns = int(columns), h.mRows = int(rows);
    h.mCell = cell;
    h.mX0 = xCentre ? header["xllcenter"] : header["xllcorner"] + 0.5 * h.mCell;
    h.mZ0 = zCentre ? header["yllcenter"] : header["yllcorner"] + 0.5 * h.mCell;
    if (!(std::abs(h.mX0) <= kMaxCoordinate && std::abs(h.mZ0) <= kMaxCoordinate))
        fail(path, 1,
             "the lower-left corner must be within " + formatNumber(kMaxCoordinate) +
                 " m of the origin");
    const bool hasNoData = header.count("nodata_value");
    const double noData = hasNoData ? header["nodata_value"] : 0.0;

    // Heights in file order, as many as the data holds: memory follows the file's size, not
    // its header (ncols and nrows of 1e9 with no data behind them fail in the first row).
    const std::size_t cells = std::size_t(h.mColumns) * std::size_t(h.mRows);
    h.mHeight.reserve(std::min(cells, size / 2 + 1));
    in.clear();
    in.seekg(dataStart);
    for (int fileRow = 0; fileRow < h.mRows; ++fileRow) {
        for (int column = 0; column < h.mColumns; ++column) {
            const auto at = [&] {
                return " at row " + std::to_string(fileRow + 1) + ", column " +
                       std::to_string(column + 1);
            };
            double value = 0.0;
            if (!(in >> value))
                fail(path, line + fileRow + 1,
                     "expected " + std::to_string(cells) + " heights, the data ends in row " +
                         std::to_string(fileRow + 1));
            if (hasNoData && value == noData)
                fail(path, line + fileRow + 1, "NODATA cell" + at() + ": fill the DEM first");
            if (!(std::abs(value) <= kMaxHeight))
                fail(path, line + fileRow + 1,
                     "height " + formatNumber(value) + at() + " is not within " +
                         formatNumber(kMaxHeight) + " m of 0");
            h.mHeight.push_back(float(value));
        }
    }
    // The file starts in the north; rows are stored from the south.
    for (int fileRow = 0, row = h.mRows - 1; fileRow < row; ++fileRow, --row) {
        const auto north = h.mHeight.begin() + std::ptrdiff_t(fileRow) * h.mColumns;
        std::swap_ranges(north, north + h.mColumns,
                         h.mHeight.begin() + std::ptrdiff_t(row) * h.mColumns);
    }
    return h;
}

float Heightfield::at(int column, int row) const {
    return mHeight[std::size_t(row) * mColumns + column];
}

void Heightfield::locate(float x, float z, int& i, int& j, float& fx, float& fz) const {
    const double u = std::clamp((x - mX0) / mCell, 0.0, double(mColumns - 1));
    const double v = std::clamp((z - mZ0) / mCell, 0.0, double(mRows - 1));
    i = std::min(int(u), mColumns - 2);
    j = std::min(int(v), mRows - 2);
    fx = float(u - i), fz = float(v - j);
}

float Heightfield::heightAt(float x, float z) const {
    int i = 0, j = 0;
    float fx = 0.f, fz = 0.f;
    locate(x, z, i, j, fx, fz);
    const float south = at(i, j) + fx * (at(i + 1, j) - at(i, j));
    const float north = at(i, j + 1) + fx * (at(i + 1, j + 1) - at(i, j + 1));
    return south + fz * (north - south);
}

void Heightfield::gradientAt(float x, float z, float& dhdx, float& dhdz) const {
    int i = 0, j = 0;
    float fx = 0.f, fz = 0.f;
    locate(x, z, i, j, fx, fz);
    const float cell = float(mCell);
    dhdx = ((1.f - fz) * (at(i + 1, j) - at(i, j)) + fz * (at(i + 1, j + 1) - at(i, j + 1))) / cell;
    dhdz = ((1.f - fx) * (at(i, j + 1) - at(i, j)) + fx * (at(i + 1, j + 1) - at(i + 1, j))) / cell;
}

} // namespace firn
