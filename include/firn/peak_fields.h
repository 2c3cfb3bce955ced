// Hazard maps: peak flow thickness, speed and pressure over a run on a DEM's grid, written as
// GeoTIFF and ESRI ASCII rasters in the DEM's CRS (AvaFrame's names: pft, pfv, ppr).
#pragma once

#include <firn/gis.h>
#include <firn/particles.h>
#include <firn/serial.h>

#include <array>
#include <string>
#include <vector>

namespace firn {

/// The peaks of a run's flow fields on a raster grid, accumulated step by step.
///
/// Per cell and sample, each particle spread over the four nearest cell centres with bilinear
/// weights (cloud-in-cell): flow thickness h = the particles' volumes / cell area x cos(slope)
/// (normal to the terrain; the volumes are the seeded ones, so h is snow at its release
/// density); speed u = the mass-weighted mean particle speed; pressure = rho u^2 with rho the
/// cell's mass over that volume, in kPa as AvaFrame writes it. The peaks are the largest of each
/// over every sample; the deposit is the thickness of the last sample.
class PeakFields {
public:
    PeakFields() = default;
    /// On the grid `geo` (scene coordinates), for a simulation whose local frame starts at
    /// `origin`; `slope` gives the terrain's cos(slope) at the cell centres (the DEM in the local
    /// frame).
    PeakFields(const Georeference& geo, const Vec3d& origin, const Heightfield& slope);

    bool empty() const { return mColumns == 0; }

    /// Adds one sample of the particles' state. Serial, in particle order: the same for any
    /// thread count.
    void accumulate(const ParticleSet& particles);

    /// After a step of `dt` whose fastest particle moved at `maxSpeed`: samples once the
    /// fastest snow can have crossed kSampleTravel of a cell since the last sample (every step
    /// of a fast flow on a fine raster, rarely at rest). Returns whether it sampled.
    bool afterStep(const ParticleSet& particles, double maxSpeed, double dt);

    /// The travel between samples, in cells: peaks move at most a fifth of a cell unseen.
    static constexpr double kSampleTravel = 0.2;

    /// Writes `dir/pft`, `pfv`, `ppr` and `dft` (deposit flow thickness), each as `.tif` and
    /// `.asc`, on the grid and CRS of `geo`; cells snow never reached hold 0. Beside them, for
    /// maps: `release` (the thickness of the first sample, the release) and `dem` (the terrain's
    /// elevation at the cell centres, m). Throws IoError.
    void write(const std::string& dir) const;

    /// Peak values of cell (column, row), rows from the south.
    float peakThickness(int column, int row) const { return mPeakThickness[index(column, row)]; }
    float peakSpeed(int column, int row) const { return mPeakSpeed[index(column, row)]; }
    float peakPressure(int column, int row) const { return mPeakPressure[index(column, row)]; }
    float depositThickness(int column, int row) const { return mDeposit[index(column, row)]; }
    /// The centres of the cells whose peak pressure reached `kPa`: (x, elevation, z), m, in
    /// the simulation's frame, rows from the south.
    std::vector<std::array<double, 3>> footprint(double kPa) const;
    int columns() const { return mColumns; }
    int rows() const { return mRows; }
    long long samples() const { return mSamples; }

    void save(ByteWriter& out) const;
    void load(ByteReader& in);

private:
    Georeference mGeo;
    int mColumns = 0, mRows = 0;
    double mWest = 0, mSouth = 0, mCell = 1; // in the local frame
    std::vector<float> mCosSlope;
    std::vector<float> mPeakThickness, mPeakSpeed, mPeakPressure, mDeposit, mRelease;
    std::vector<float> mElevation;
    // One sample's sums, and the cells it touched (cleared after the sample).
    std::vector<double> mMass, mVolume, mMomentum;
    std::vector<std::uint32_t> mTouched, mLastTouched;
    long long mSamples = 0;
    double mTravel = 0.0; // m, the fastest snow's since the last sample

    std::size_t index(int column, int row) const {
        return std::size_t(row) * std::size_t(mColumns) + std::size_t(column);
    }
};

/// The raster grid of a run's peak fields: the first heightfield DEM's, or one of `cell` m
/// (output.raster_cell, > 0) over the DEM's extent; not georeferenced (columns 0) when the
/// scene has no heightfield or output.rasters is off.
Georeference peakFieldGrid(const SceneDesc& scene);

/// Writes one raster as `path.tif` (GeoTIFF, Float32) and `path.asc` (ESRI ASCII grid with a
/// .prj when the CRS is known), rows from the south in `values`. Throws IoError.
void writeRaster(const std::string& path, const Georeference& geo,
                 const std::vector<float>& values);

} // namespace firn
