// Seed writers for the image and wire-message fuzz targets (make_wire_seeds.cc).
#pragma once

#include <filesystem>
#include <string>

namespace semmap::fuzz {

// Writes dir/name (creating dir); false when it cannot.
bool WriteSeedFile(const std::filesystem::path& dir, const std::string& name,
                   const std::string& bytes);

bool ImageSeeds(const std::filesystem::path& dir);    // image_decode
bool IngestSeeds(const std::filesystem::path& dir);   // ingest_request
bool RequestSeeds(const std::filesystem::path& dir);  // rpc_requests

}  // namespace semmap::fuzz
