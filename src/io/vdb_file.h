// Writing a .vdb file the way every Firn output does (io module internal): Blosc compression
// (zlib where OpenVDB lacks Blosc), a content-derived file UUID so that the same grids give the
// same bytes, and an atomic write (temporary name, fsync, rename) that checks every write.
#pragma once

#include <openvdb/openvdb.h>

#include <string>

namespace firn {

/// Throws IoError naming `path`.
void writeVdbFileAtomic(const std::string& path, const openvdb::GridCPtrVec& grids);

} // namespace firn
