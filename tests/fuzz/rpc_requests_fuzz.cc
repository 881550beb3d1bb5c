// Every other request message as a handler reads it (server/serialization/request_conversions and
// server/serialization/conversions): the first byte picks the message type, the rest is its wire
// bytes. What parses converts without a crash; conversions that can refuse do so with
// INVALID_ARGUMENT.
#include <cstdint>
#include <string>

#include "server/serialization/conversions.h"
#include "server/serialization/request_conversions.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

template <typename Message>
bool Parse(std::string_view bytes, Message* message) {
  return message->ParseFromArray(bytes.data(), static_cast<int>(bytes.size()));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  if (size < 1) return 0;
  const std::string_view bytes = fuzz::AsText(data + 1, size - 1);
  switch (data[0] % 8) {
    case 0: {
      v1::RegisterObjectRequest request;
      if (!Parse(bytes, &request)) return 0;
      StatusOr<RegisterObjectInput> input = FromProto(request);
      if (!input.ok()) {
        FUZZ_CHECK(input.status().code() == StatusCode::kInvalidArgument);
      } else {
        FUZZ_CHECK(input->photos.size() == static_cast<size_t>(request.photos_size()));
      }
      break;
    }
    case 1: {
      v1::ExportMapRequest request;
      if (!Parse(bytes, &request)) return 0;
      const ExportRequest out = FromProto(request);
      FUZZ_CHECK(out.width_px >= 0 && out.width_px <= (1 << 20));
      break;
    }
    case 2: {
      v1::ObjectsNearRequest request;
      if (!Parse(bytes, &request)) return 0;
      (void)FromProto(request);
      break;
    }
    case 3: {
      v1::CameraCalibration request;
      if (!Parse(bytes, &request)) return 0;
      StatusOr<CameraCalibration> camera = FromProto(request);
      if (!camera.ok()) FUZZ_CHECK(camera.status().code() == StatusCode::kInvalidArgument);
      break;
    }
    case 4: {
      v1::Pose request;
      if (!Parse(bytes, &request)) return 0;
      const PoseTq pose = FromProto(request);
      if (ValidatePoseTq(pose).ok()) FUZZ_CHECK(ToIsometry(pose).matrix().allFinite());
      break;
    }
    case 5: {
      v1::SessionInfo request;  // what the client library reads back
      if (!Parse(bytes, &request)) return 0;
      (void)FromProto(request);
      break;
    }
    case 6: {
      v1::TrajectoryPose request;
      if (!Parse(bytes, &request)) return 0;
      (void)FromProto(request);
      break;
    }
    default: {
      // The remaining requests carry only names, read as they are; parsing must hold.
      v1::RemoveSessionRequest remove_session;
      v1::GetTrajectoryRequest trajectory;
      v1::FindObjectsRequest find;
      (void)Parse(bytes, &remove_session);
      (void)Parse(bytes, &trajectory);
      (void)Parse(bytes, &find);
      break;
    }
  }
  return 0;
}
