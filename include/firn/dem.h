// Digital elevation models: ESRI ASCII grids (.asc) as a terrain height y(x, z).
#pragma once

#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

namespace firn {

/// What a DEM's NODATA cells become: an error that names them (the default), or heights filled
/// in from the valid cells around them (`[[terrain]] nodata = "fill"`).
enum class NoDataPolicy { Error, Fill };

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
    static Heightfield readEsriAscii(const std::string& path,
                                     NoDataPolicy noData = NoDataPolicy::Error);
    /// The same from the file's text; `path` names the file in messages.
    static Heightfield parseEsriAscii(const std::string& text, const std::string& path,
                                      NoDataPolicy noData = NoDataPolicy::Error);
    /// A grid from heights already read (row-major from the south, NaN for NODATA), with the
    /// centre of its south-west cell at (x0, z0); the bounds below are checked and NODATA is
    /// treated by `noData`. Throws SceneError naming `path`.
    static Heightfield fromGrid(int columns, int rows, double x0, double z0, double cell,
                                std::vector<float> heights, const std::string& path,
                                NoDataPolicy noData);

    /// Far outside any real DEM, these keep the collider's float heights, slopes and normals
    /// finite (fuzz/README.md).
    static constexpr double kMinCell = 1e-6, kMaxCell = 1e6; ///< m
    static constexpr double kMaxHeight = 1e6;                ///< |height|, m
    static constexpr double kMaxCoordinate = 1e9;            ///< |centre of the lower-left cell|, m

    /// The same ground moved by (-dx, -dz): the DEM in a local frame whose origin sits at
    /// (dx, dz) of the DEM's coordinates (GIS DEMs lie 1e5-1e6 m from 0, beyond float).
    Heightfield shiftedBy(double dx, double dz) const;

    float heightAt(float x, float z) const;
    /// dh/dx and dh/dz of the bilinear interpolant at (x, z).
    void gradientAt(float x, float z, float& dhdx, float& dhdz) const;
    /// heightAt and gradientAt together, bitwise theirs, from one cell lookup.
    void sampleAt(float x, float z, float& height, float& dhdx, float& dhdz) const;

    int columns() const { return mColumns; }
    int rows() const { return mRows; }
    double cellSize() const { return mCell; }
    /// Centre of the south-west cell, m (in the frame the grid was shifted to).
    double x0() const { return mX0; }
    double z0() const { return mZ0; }
    /// Height of cell (column, row), rows from the south.
    float cell(int column, int row) const { return at(column, row); }
    /// NODATA cells filled in (NoDataPolicy::Fill).
    std::size_t filledCells() const { return mFilled; }

private:
    int mColumns = 0, mRows = 0;
    double mX0 = 0.0, mZ0 = 0.0; // centre of the south-west cell, m
    double mCell = 1.0;          // m
    std::vector<float> mHeight;  // row-major from the south: index = row * columns + column
    std::size_t mFilled = 0;

    /// The reader of both: `size` bounds the memory reserved before the heights are read.
    static Heightfield parse(std::istream& in, std::size_t size, const std::string& path,
                             NoDataPolicy noData);
    /// Fills the NaN cells from their valid neighbours, from the edges of each hole inward.
    void fillNoData(const std::string& path);
    float at(int column, int row) const;
    /// Cell and fractions of (x, z), clamped to the grid.
    void locate(float x, float z, int& i, int& j, float& fx, float& fz) const;
    /// The bilinear height and gradient in cell (i, j) at fractions (fx, fz).
    float heightIn(int i, int j, float fx, float fz) const;
    void gradientIn(int i, int j, float fx, float fz, float& dhdx, float& dhdz) const;
};

} // namespace firn
