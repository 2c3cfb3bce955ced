// Peak flow fields on a raster grid, and raster output through GDAL.
#include "gdal_session.h"

#include <firn/errors.h>
#include <firn/io.h>
#include <firn/peak_fields.h>

#include <cpl_conv.h>
#include <gdal.h>
#include <ogr_srs_api.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>

namespace firn {

PeakFields::PeakFields(const Georeference& geo, const Vec3d& origin, const Heightfield& slope)
    : mGeo(geo)
    , mColumns(geo.columns)
    , mRows(geo.rows)
    , mWest(geo.west - origin[0])
    , mSouth(geo.south - origin[2])
    , mCell(geo.cell) {
    const std::size_t cells = std::size_t(mColumns) * std::size_t(mRows);
    mCosSlope.resize(cells);
    mElevation.resize(cells);
    for (int row = 0; row < mRows; ++row)
        for (int column = 0; column < mColumns; ++column) {
            const float x = float(mWest + (column + 0.5) * mCell);
            const float z = float(mSouth + (row + 0.5) * mCell);
            float hx = 0.f, hz = 0.f;
            slope.gradientAt(x, z, hx, hz);
            mCosSlope[index(column, row)] = 1.f / std::sqrt(1.f + hx * hx + hz * hz);
            mElevation[index(column, row)] = float(slope.heightAt(x, z) + origin[1]);
        }
    for (auto* v : {&mPeakThickness, &mPeakSpeed, &mPeakPressure, &mDeposit, &mRelease})
        v->assign(cells, 0.f);
    for (auto* v : {&mMass, &mVolume, &mMomentum}) v->assign(cells, 0.0);
}

void PeakFields::accumulate(const ParticleSet& ps) {
    if (empty()) return;
    const double inverseCell = 1.0 / mCell;
    // Cloud-in-cell: each particle spreads over the four cells whose centres surround it, with
    // bilinear weights. Binning into one cell aliases a particle lattice against the raster (a
    // 5 m cell over particles 2 m apart holds 4, 6 or 9 columns: +-40 % of thickness), and the
    // peak over many samples would keep the highest of that noise.
    // In parallel over bands of rows: each band's task reads every particle and deposits into
    // its own rows, so each cell's sum runs in particle order whatever the thread count.
    const int bands = std::clamp(mRows / 16, 1, tbb::this_task_arena::max_concurrency());
    std::vector<std::vector<std::uint32_t>> touched(static_cast<std::size_t>(bands));
    tbb::parallel_for(0, bands, [&](int band) {
        const int rowBegin = int(std::int64_t(mRows) * band / bands),
                  rowEnd = int(std::int64_t(mRows) * (band + 1) / bands);
        std::vector<std::uint32_t>& touchedHere = touched[std::size_t(band)];
        auto deposit = [&](int column, int row, double w, double m, double vol, double mu) {
            if (column < 0 || row < rowBegin || column >= mColumns || row >= rowEnd || w <= 0.0)
                return;
            const std::size_t c = index(column, row);
            if (mMass[c] == 0.0) touchedHere.push_back(std::uint32_t(c));
            mMass[c] += w * m;
            mVolume[c] += w * vol;
            mMomentum[c] += w * mu;
        };
        for (std::size_t i = 0; i < ps.size(); ++i) {
            const Vec3f& x = ps.x[i];
            const double u = (x[0] - mWest) * inverseCell - 0.5,
                         v = (x[2] - mSouth) * inverseCell - 0.5;
            if (!(u > -1.0 && v > -1.0 && u < mColumns && v < mRows)) continue; // off the grid
            const int i0 = int(std::floor(u)), j0 = int(std::floor(v));
            if (j0 + 1 < rowBegin || j0 >= rowEnd) continue; // neither row is this band's
            const double fu = u - i0, fv = v - j0;
            const double m = ps.mass[i], vol = ps.volume0[i], mu = m * double(ps.v[i].norm());
            deposit(i0, j0, (1 - fu) * (1 - fv), m, vol, mu);
            deposit(i0 + 1, j0, fu * (1 - fv), m, vol, mu);
            deposit(i0, j0 + 1, (1 - fu) * fv, m, vol, mu);
            deposit(i0 + 1, j0 + 1, fu * fv, m, vol, mu);
        }
    });
    for (const auto& list : touched) mTouched.insert(mTouched.end(), list.begin(), list.end());
    // A cell is listed when its mass leaves zero; a particle without mass would list it twice,
    // and the parallel pass below must see each cell once.
    std::sort(mTouched.begin(), mTouched.end());
    mTouched.erase(std::unique(mTouched.begin(), mTouched.end()), mTouched.end());
    const double area = mCell * mCell;
    // The deposit is the last sample: cells the snow has left go back to 0 (only those the
    // previous sample touched: clearing the whole raster each step would cost more than the
    // sampling itself for small releases on large DEMs).
    for (std::uint32_t c : mLastTouched) mDeposit[c] = 0.f;
    const bool first = mSamples == 0;
    tbb::parallel_for(
        tbb::blocked_range<std::size_t>(0, mTouched.size(), 1024), [&](const auto& r) {
            for (std::size_t k = r.begin(); k != r.end(); ++k) {
                const std::uint32_t c = mTouched[k];
                const double thickness = mVolume[c] / area * mCosSlope[c];
                const double speed = mMomentum[c] / mMass[c];
                const double pressure = mMass[c] / mVolume[c] * speed * speed / 1000.0; // kPa
                mPeakThickness[c] = std::max(mPeakThickness[c], float(thickness));
                mPeakSpeed[c] = std::max(mPeakSpeed[c], float(speed));
                mPeakPressure[c] = std::max(mPeakPressure[c], float(pressure));
                mDeposit[c] = float(thickness);
                if (first) mRelease[c] = float(thickness);
                mMass[c] = mVolume[c] = mMomentum[c] = 0.0;
            }
        });
    mLastTouched.swap(mTouched);
    mTouched.clear();
    ++mSamples;
}

bool PeakFields::afterStep(const ParticleSet& particles, double maxSpeed, double dt) {
    if (empty()) return false;
    mTravel += maxSpeed * dt;
    if (mTravel < kSampleTravel * mCell) return false;
    accumulate(particles);
    mTravel = 0.0;
    return true;
}

std::vector<std::array<double, 3>> PeakFields::footprint(double kPa) const {
    std::vector<std::array<double, 3>> cells;
    for (int row = 0; row < mRows; ++row)
        for (int column = 0; column < mColumns; ++column)
            if (mPeakPressure[index(column, row)] >= kPa)
                cells.push_back({mWest + (column + 0.5) * mCell, mElevation[index(column, row)],
                                 mSouth + (row + 0.5) * mCell});
    return cells;
}

void PeakFields::write(const std::string& dir) const {
    if (empty()) return;
    makeDirectories(dir);
    writeRaster(dir + "/pft", mGeo, mPeakThickness);
    writeRaster(dir + "/pfv", mGeo, mPeakSpeed);
    writeRaster(dir + "/ppr", mGeo, mPeakPressure);
    writeRaster(dir + "/dft", mGeo, mDeposit);
    writeRaster(dir + "/release", mGeo, mRelease);
    writeRaster(dir + "/dem", mGeo, mElevation);
}

void PeakFields::save(ByteWriter& out) const {
    out.value(mSamples);
    out.value(mTravel);
    for (const auto* v : {&mPeakThickness, &mPeakSpeed, &mPeakPressure, &mDeposit, &mRelease})
        out.array(*v);
}

void PeakFields::load(ByteReader& in) {
    in.value(mSamples);
    in.value(mTravel);
    const std::size_t cells = mCosSlope.size();
    for (auto* v : {&mPeakThickness, &mPeakSpeed, &mPeakPressure, &mDeposit, &mRelease}) {
        in.array(*v);
        if (v->size() != cells) throw ByteReadError("peak fields of another grid");
    }
    // The cells the last sample touched, which the next one clears from the deposit.
    mLastTouched.clear();
    for (std::size_t c = 0; c < cells; ++c)
        if (mDeposit[c] != 0.f) mLastTouched.push_back(std::uint32_t(c));
}

Georeference peakFieldGrid(const SceneDesc& scene) {
    if (!scene.output.rasters) return {};
    for (const TerrainDesc& t : scene.terrains) {
        if (t.shape != TerrainShape::Heightfield) continue;
        Georeference geo = readDemGeoreference(t.file);
        const double cell = scene.output.rasterCell;
        if (cell > 0.0 && cell != geo.cell) {
            // The DEM's extent, in cells of the requested size (the last one may overhang).
            geo.columns = std::max(1, int(std::ceil(geo.columns * geo.cell / cell - 1e-9)));
            geo.rows = std::max(1, int(std::ceil(geo.rows * geo.cell / cell - 1e-9)));
            geo.cell = cell;
        }
        return geo;
    }
    return {};
}

namespace {

using gis::Dataset;

[[noreturn]] void rasterError(const std::string& path, const std::string& what) {
    const std::string why = CPLGetLastErrorMsg();
    throw IoError("cannot write " + path + ": " + what + (why.empty() ? "" : ": " + why));
}

/// Copies `source` to `path` with `driver`, through a temporary name in the same folder, so
/// that a raster appears only complete (as every output).
void copyAtomic(GDALDatasetH source, const char* driverName, const std::string& path) {
    GDALDriverH driver = GDALGetDriverByName(driverName);
    if (!driver) rasterError(path, std::string("GDAL has no ") + driverName + " driver");
    const std::filesystem::path final(path);
    const std::filesystem::path tmp =
        final.parent_path() / (".tmp." + final.stem().string() + final.extension().string());
    CPLErrorReset();
    Dataset copy(
        GDALCreateCopy(driver, tmp.string().c_str(), source, FALSE, nullptr, nullptr, nullptr));
    if (!copy) rasterError(path, "GDAL could not create it");
    copy.reset(); // closing flushes; a full disk shows here
    if (CPLGetLastErrorType() >= CE_Failure) rasterError(path, "GDAL could not write it");
    // The drivers may write side files next to it (.prj, .aux.xml): rename those as well.
    std::error_code ec;
    for (const char* side : {"", ".prj", ".aux.xml"}) {
        std::filesystem::path from = tmp, to = final;
        if (std::string(side) == ".prj")
            from.replace_extension(".prj"), to.replace_extension(".prj");
        else
            from += side, to += side;
        if (!std::filesystem::exists(from, ec)) continue;
        std::filesystem::rename(from, to, ec);
        if (ec) throw IoError("cannot rename " + from.string() + ": " + ec.message());
    }
}

} // namespace

void writeRaster(const std::string& path, const Georeference& geo,
                 const std::vector<float>& values) {
    gis::ensureGdal();
    GDALDriverH mem = GDALGetDriverByName("MEM");
    Dataset d(GDALCreate(mem, "", geo.columns, geo.rows, 1, GDT_Float32, nullptr));
    if (!d) rasterError(path, "GDAL could not create the raster in memory");
    // North-up: GDAL's first row is the north one.
    double t[6] = {geo.west, geo.cell, 0.0, geo.south + geo.cell * geo.rows, 0.0, -geo.cell};
    GDALSetGeoTransform(d.get(), t);
    if (!geo.crsWkt.empty()) GDALSetProjection(d.get(), geo.crsWkt.c_str());
    GDALRasterBandH band = GDALGetRasterBand(d.get(), 1);
    for (int fileRow = 0; fileRow < geo.rows; ++fileRow) {
        const float* row = values.data() + std::size_t(geo.rows - 1 - fileRow) * geo.columns;
        if (GDALRasterIO(band, GF_Write, 0, fileRow, geo.columns, 1, const_cast<float*>(row),
                         geo.columns, 1, GDT_Float32, 0, 0) != CE_None)
            rasterError(path, "GDAL could not fill the raster");
    }
    copyAtomic(d.get(), "GTiff", path + ".tif");
    copyAtomic(d.get(), "AAIGrid", path + ".asc");
}

} // namespace firn
