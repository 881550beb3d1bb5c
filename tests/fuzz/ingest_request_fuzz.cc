// The Ingest stream's messages as they come off the wire (server/serialization/ingest_conversions):
// bytes -> IngestRequest -> pipeline message, then what the session's decoder does with a frame
// (image decoding against the start's camera). Garbage, truncation and invalid UTF-8 must come
// out as IngestInvalid with INVALID_ARGUMENT, never as anything the session would store.
#include <cstdint>
#include <string>
#include <variant>

#include "core/sensor/image_decoding.h"
#include "server/serialization/ingest_conversions.h"
#include "tests/fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace semmap;
  const IngestMessage message = ParseIngestRequest(fuzz::AsText(data, size), 1);
  if (const auto* invalid = std::get_if<IngestInvalid>(&message)) {
    FUZZ_CHECK(invalid->status.code() == StatusCode::kInvalidArgument);
    FUZZ_CHECK(!invalid->status.message().empty());
    return 0;
  }
  if (const auto* frame = std::get_if<IngestFrame>(&message)) {
    size_t payload = 0;
    if (frame->colour) payload += frame->colour->data.size();
    if (frame->depth) payload += frame->depth->image.data.size();
    FUZZ_CHECK(frame->payload_bytes == payload);
    // The session decodes against its camera; 640x480 stands for any.
    if (frame->colour) {
      StatusOr<cv::Mat> colour = DecodeColour(*frame->colour, 640, 480);
      if (colour.ok()) FUZZ_CHECK(colour->cols == 640 && colour->rows == 480);
    }
    if (frame->depth) {
      StatusOr<DecodedDepth> depth = DecodeDepth(*frame->depth, 640, 480);
      if (depth.ok()) FUZZ_CHECK(depth->raw.cols == 640 && depth->raw.type() == CV_16UC1);
    }
  }
  if (const auto* start = std::get_if<IngestStartRequest>(&message)) {
    // A start that converted has a calibration that passed FromProto's checks.
    FUZZ_CHECK(start->camera.width >= 0 && start->camera.height >= 0);
  }
  return 0;
}
