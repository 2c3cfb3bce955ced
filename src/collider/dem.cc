#include <firn/dem.h>
#include <firn/errors.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

namespace firn {

namespace {

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

[[noreturn]] void fail(const std::string& path, int line, const std::string& what) {
    throw SceneError(SourceLoc{path, line, 0}, "heightfield", what);
}

} // namespace

Heightfield Heightfield::readEsriAscii(const std::string& path) {
    std::ifstream in(path);
    if (!in) fail(path, 0, "cannot open the DEM file");
    std::map<std::string, double> header;
    std::string text;
    int line = 0;
    std::streampos dataStart = in.tellg();
    while (std::getline(in, text)) {
        ++line;
        std::istringstream words(text);
        std::string key;
        double value = 0.0;
        if (!(words >> key) || std::isdigit(static_cast<unsigned char>(key[0])) || key[0] == '-' ||
            key[0] == '.') {
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

    Heightfield h;
    h.mColumns = int(header["ncols"]), h.mRows = int(header["nrows"]);
    h.mCell = header["cellsize"];
    if (h.mColumns < 2 || h.mRows < 2 || !(h.mCell > 0.0))
        fail(path, 1, "needs ncols >= 2, nrows >= 2 and cellsize > 0");
    h.mX0 = xCentre ? header["xllcenter"] : header["xllcorner"] + 0.5 * h.mCell;
    h.mZ0 = zCentre ? header["yllcenter"] : header["yllcorner"] + 0.5 * h.mCell;
    const bool hasNoData = header.count("nodata_value");
    const double noData = hasNoData ? header["nodata_value"] : 0.0;

    in.clear();
    in.seekg(dataStart);
    h.mHeight.assign(std::size_t(h.mColumns) * h.mRows, 0.f);
    for (int fileRow = 0; fileRow < h.mRows; ++fileRow) {
        const int row = h.mRows - 1 - fileRow; // the file starts in the north
        for (int column = 0; column < h.mColumns; ++column) {
            double value = 0.0;
            if (!(in >> value))
                fail(path, line + fileRow + 1,
                     "expected " + std::to_string(h.mColumns * h.mRows) +
                         " heights, the data "
                         "ends in row " +
                         std::to_string(fileRow + 1));
            if (hasNoData && value == noData)
                fail(path, line + fileRow + 1,
                     "NODATA cell at row " + std::to_string(fileRow + 1) + ", column " +
                         std::to_string(column + 1) + ": fill the DEM first");
            h.mHeight[std::size_t(row) * h.mColumns + column] = float(value);
        }
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
