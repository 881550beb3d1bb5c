// Decoder of stored keyframe features (DecodeFeatures, semmap-features-v1 blobs). What decodes
// is index-aligned, and encoding it gives bytes that decode to the same features (a second
// encoding is byte-identical to the first).
#include <cstdint>
#include <string>

#include "core/slam/feature_codec.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

void CheckAligned(const semmap::FrameFeatures& f) {
  FUZZ_CHECK(f.has_depth.size() == f.size() && f.points_camera.size() == f.size());
  if (!f.descriptors.empty()) {
    FUZZ_CHECK(static_cast<size_t>(f.descriptors.rows) == f.size());
    FUZZ_CHECK(f.descriptors.type() == CV_8U || f.descriptors.type() == CV_32F);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  const std::string_view input = fuzz::AsText(data, size);
  StatusOr<FrameFeatures> f = DecodeFeatures(kFeatureCodecFormat, input);
  FUZZ_CHECK(DecodeFeatures("semmap-features-v0", input).status().code() ==
             StatusCode::kInvalidArgument);
  if (!f.ok()) {
    FUZZ_CHECK(f.status().code() == StatusCode::kDataLoss);
    return 0;
  }
  CheckAligned(*f);
  const std::string once = EncodeFeatures(*f);
  StatusOr<FrameFeatures> again = DecodeFeatures(kFeatureCodecFormat, once);
  FUZZ_CHECK(again.ok());
  CheckAligned(*again);
  FUZZ_CHECK(again->size() == f->size());
  FUZZ_CHECK(again->has_depth == f->has_depth);
  FUZZ_CHECK(again->descriptors.size() == f->descriptors.size());
  FUZZ_CHECK(EncodeFeatures(*again) == once);
  return 0;
}
