// Digital elevation models: ESRI ASCII grids (.asc) as a terrain height y(x, z).
#pragma once

#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

namespace firn {

/// A regular grid of ground heights. The DEM's easting is the scene's x, its northing the
/// scene's z, its elevation the scene's y (up). Heights are sampled at cell centres and
/// interpolated bilinearly; outside the grid the edge values continue.
class Heightfield {
public:
    /// Reads an ESRI ASCII grid (ncols, nrows, xllcorner|xllcenter, yllcorner|yllcenter,
    /// cellsize, optional NODATA_value, then nrows rows from north to south). Throws
    /// SceneError naming the file and line of what is wrong (NODATA cells included), and for
    /// values no DEM holds: cellsize outside [1e-6, 1e6] m, heights beyond +-1e6 m, a corner
    /// beyond 1e9 m; these bounds keep the collider's float heights and slopes finite.
    static Heightfield readEsriAscii(const std::string& path);
    /// The same from the file's text; `path` names the file in messages.
    static Heightfield parseEsriAscii(const std::string& text, const std::string& path);

    float heightAt(float x, float z) const;
    /// dh/dx and dh/dz of the bilinear interpolant at (x, z).
    void gradientAt(float x, float z, float& dhdx, float& dhdz) const;

    int columns() const { return mColumns; }
    int rows() const { return mRows; }

private:
    int mColumns = 0, mRows = 0;
    double mX0 = 0.0, mZ0 = 0.0; // centre of the south-west cell, m
    double mCell = 1.0;          // m
    std::vector<float> mHeight;  // row-major from the south: index = row * columns + column

    /// The reader of both: `size` bounds the memory reserved before the heights are read.
    static Heightfield parse(std::istream& in, std::size_t size, const std::string& path);
    float at(int column, int row) const;
    /// Cell and fractions of (x, z), clamped to the grid.
    void locate(float x, float z, int& i, int& j, float& fx, float& fz) const;
};

} // namespace firn
