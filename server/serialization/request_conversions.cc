#include "server/serialization/request_conversions.h"

#include <algorithm>
#include <cstdint>

#include "server/serialization/object_conversions.h"

namespace semmap {

StatusOr<RegisterObjectInput> FromProto(const v1::RegisterObjectRequest& request) {
  RegisterObjectInput input;
  input.label = request.label();
  input.map = request.map();
  for (const v1::CompressedImage& photo : request.photos()) {
    input.photos.push_back({photo.format(), photo.data()});
  }
  if (request.has_colour()) {
    const v1::Colour& c = request.colour();
    if (c.r() > 255 || c.g() > 255 || c.b() > 255) {
      return InvalidArgumentError("colour channels must be 0..255");
    }
    input.rgb = FromProto(c);
  }
  return input;
}

ExportRequest FromProto(const v1::ExportMapRequest& request) {
  ExportRequest out;
  out.map = request.map();
  out.format = request.format();
  out.session = request.session();
  out.ascii = request.ascii();
  out.voxel_m = request.voxel();
  out.view = request.view();
  out.width_px = static_cast<int>(std::min<uint32_t>(request.width(), 1u << 20));
  return out;
}

NearQuery FromProto(const v1::ObjectsNearRequest& request) {
  NearQuery out;
  out.map = request.map();
  out.point = FromProto(request.point());
  out.radius_m = request.radius();
  out.label = request.label();
  return out;
}

}  // namespace semmap
