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

Heightfield Heightfield::readEsriAscii(const std::string& path, NoDataPolicy noData) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) fail(path, 0, "cannot open the DEM file");
    const std::streamoff size = in.tellg();
    in.seekg(0);
    return parse(in, std::size_t(std::max<std::streamoff>(size, 0)), path, noData);
}

Heightfield Heightfield::parseEsriAscii(const std::string& text, const std::string& path,
                                        NoDataPolicy noData) {
    std::istringstream in(text);
    return parse(in, text.size(), path, noData);
}

Heightfield Heightfield::parse(std::istream& in, std::size_t size, const std::string& path,
                               NoDataPolicy noData) {
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
    const double noDataValue = hasNoData ? header["nodata_value"] : 0.0;

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
            if (hasNoData && value == noDataValue) {
                if (noData == NoDataPolicy::Error)
                    fail(path, line + fileRow + 1,
                         "NODATA cell" + at() +
                             ": fill the DEM first, or set nodata = \"fill\" on the terrain");
                h.mHeight.push_back(std::numeric_limits<float>::quiet_NaN());
                continue;
            }
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
    if (noData == NoDataPolicy::Fill) h.fillNoData(path);
    return h;
}

Heightfield Heightfield::fromGrid(int columns, int rows, double x0, double z0, double cell,
                                  std::vector<float> heights, const std::string& path,
                                  NoDataPolicy noData) {
    if (columns < 2 || rows < 2) fail(path, 0, "needs at least 2 x 2 cells");
    if (!(cell >= kMinCell && cell <= kMaxCell))
        fail(path, 0,
             "cell size " + formatNumber(cell) + " m is not in [" + formatNumber(kMinCell) + ", " +
                 formatNumber(kMaxCell) + "] m");
    if (!(std::abs(x0) <= kMaxCoordinate && std::abs(z0) <= kMaxCoordinate))
        fail(path, 0,
             "the lower-left corner must be within " + formatNumber(kMaxCoordinate) +
                 " m of the origin");
    if (heights.size() != std::size_t(columns) * std::size_t(rows))
        fail(path, 0,
             "holds " + std::to_string(heights.size()) + " heights, not " +
                 std::to_string(columns) + " x " + std::to_string(rows));
    Heightfield h;
    h.mColumns = columns, h.mRows = rows;
    h.mX0 = x0, h.mZ0 = z0, h.mCell = cell;
    h.mHeight = std::move(heights);
    std::size_t missing = 0;
    std::string first;
    for (int row = rows - 1; row >= 0; --row) // in reading order: from the north
        for (int column = 0; column < columns; ++column) {
            const float value = h.at(column, row);
            // Rows and columns as GIS tools count them: row 1 in the north.
            const std::string where =
                "row " + std::to_string(rows - row) + ", column " + std::to_string(column + 1);
            if (std::isnan(value)) {
                if (missing++ == 0) first = where;
            } else if (!(std::abs(value) <= kMaxHeight)) {
                fail(path, 0,
                     "height " + formatNumber(value) + " at " + where + " is not within " +
                         formatNumber(kMaxHeight) + " m of 0");
            }
        }
    if (missing > 0 && noData == NoDataPolicy::Error)
        fail(path, 0,
             std::to_string(missing) + " NODATA cell" + (missing > 1 ? "s" : "") +
                 " (the first at " + first +
                 "): fill the DEM first, or set nodata = \"fill\" on the terrain");
    if (missing > 0) h.fillNoData(path);
    return h;
}

void Heightfield::fillNoData(const std::string& path) {
    // Onion peeling, as gdal_fillnodata without smoothing: each pass gives every NODATA cell
    // beside a valid one the mean of its valid 4-neighbours, so a hole fills from its rim in.
    std::vector<std::size_t> holes;
    for (std::size_t i = 0; i < mHeight.size(); ++i)
        if (std::isnan(mHeight[i])) holes.push_back(i);
    if (holes.size() == mHeight.size()) fail(path, 0, "every cell is NODATA");
    mFilled = holes.size();
    std::vector<std::pair<std::size_t, float>> filled;
    while (!holes.empty()) {
        filled.clear();
        std::vector<std::size_t> left;
        for (std::size_t i : holes) {
            const int column = int(i % std::size_t(mColumns)), row = int(i / std::size_t(mColumns));
            float sum = 0.f;
            int count = 0;
            const int offsets[4][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
            for (const auto& o : offsets) {
                const int c = column + o[0], r = row + o[1];
                if (c < 0 || r < 0 || c >= mColumns || r >= mRows) continue;
                const float v = at(c, r);
                if (!std::isnan(v)) sum += v, ++count;
            }
            if (count > 0) {
                filled.emplace_back(i, sum / float(count));
            } else {
                left.push_back(i);
            }
        }
        for (const auto& [i, v] : filled) mHeight[i] = v;
        holes.swap(left);
    }
}

Heightfield Heightfield::shiftedBy(double dx, double dz) const {
    Heightfield h = *this;
    h.mX0 -= dx;
    h.mZ0 -= dz;
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

float Heightfield::heightIn(int i, int j, float fx, float fz) const {
    const float south = at(i, j) + fx * (at(i + 1, j) - at(i, j));
    const float north = at(i, j + 1) + fx * (at(i + 1, j + 1) - at(i, j + 1));
    return south + fz * (north - south);
}

void Heightfield::gradientIn(int i, int j, float fx, float fz, float& dhdx, float& dhdz) const {
    const float cell = float(mCell);
    dhdx = ((1.f - fz) * (at(i + 1, j) - at(i, j)) + fz * (at(i + 1, j + 1) - at(i, j + 1))) / cell;
    dhdz = ((1.f - fx) * (at(i, j + 1) - at(i, j)) + fx * (at(i + 1, j + 1) - at(i + 1, j))) / cell;
}

float Heightfield::heightAt(float x, float z) const {
    int i = 0, j = 0;
    float fx = 0.f, fz = 0.f;
    locate(x, z, i, j, fx, fz);
    return heightIn(i, j, fx, fz);
}

void Heightfield::gradientAt(float x, float z, float& dhdx, float& dhdz) const {
    int i = 0, j = 0;
    float fx = 0.f, fz = 0.f;
    locate(x, z, i, j, fx, fz);
    gradientIn(i, j, fx, fz, dhdx, dhdz);
}

void Heightfield::sampleAt(float x, float z, float& height, float& dhdx, float& dhdz) const {
    int i = 0, j = 0;
    float fx = 0.f, fz = 0.f;
    locate(x, z, i, j, fx, fz);
    height = heightIn(i, j, fx, fz);
    gradientIn(i, j, fx, fz, dhdx, dhdz);
}

} // namespace firn
