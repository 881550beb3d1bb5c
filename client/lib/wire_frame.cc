#include "client/lib/wire_frame.h"

#include <utility>

#include "client/datasets/image_file.h"
#include "server/serialization/conversions.h"

namespace semmap {
namespace {

Status ReadInto(const std::string& path, v1::Image* image) {
  SEMMAP_ASSIGN_OR_RETURN(EncodedFile file, ReadImageFile(path));
  image->mutable_compressed()->set_format(file.format);
  image->mutable_compressed()->set_data(std::move(file.bytes));
  return OkStatus();
}

}  // namespace

StatusOr<v1::Frame> MakeWireFrame(const DatasetFrame& frame, bool with_depth, double depth_scale,
                                  const std::optional<Eigen::Isometry3d>& T_world_camera) {
  v1::Frame wire;
  wire.set_seq(static_cast<uint64_t>(frame.seq));
  ToProto(frame.stamp_ns, wire.mutable_timestamp());
  if (T_world_camera) ToProto(*T_world_camera, wire.mutable_pose_prior());
  SEMMAP_RETURN_IF_ERROR(ReadInto(frame.colour_path, wire.mutable_colour()));
  if (with_depth && frame.depth_path) {
    SEMMAP_RETURN_IF_ERROR(ReadInto(*frame.depth_path, wire.mutable_depth()->mutable_image()));
    wire.mutable_depth()->set_depth_scale(depth_scale);
  }
  return wire;
}

}  // namespace semmap
