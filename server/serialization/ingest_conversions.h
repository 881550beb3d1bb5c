// Wire ingest messages -> pipeline messages (moves the image bytes, no copies) and back.
#pragma once

#include <grpcpp/support/byte_buffer.h>

#include <cstdint>
#include <string_view>

#include "core/pipeline/ingest_types.h"
#include "server/serialization/conversions.h"

namespace semmap {

// Always yields a message: a request that cannot be converted becomes IngestInvalid.
IngestMessage FromProto(v1::IngestRequest&& request);

// Parses and converts the `index`-th message (from 1) of an Ingest stream as it came off the
// wire. Bytes that are not an IngestRequest (garbage, truncated, invalid UTF-8 in a string field)
// become IngestInvalid naming the message, so the stream ends INVALID_ARGUMENT instead of looking
// like the client's half-close.
IngestMessage ParseIngestRequest(const grpc::ByteBuffer& buffer, uint64_t index);
IngestMessage ParseIngestRequest(std::string_view bytes, uint64_t index);

void ToProto(const SessionInfo& session, v1::IngestStarted* out);
void ToProto(const FrameAckInfo& ack, v1::FrameAck* out);
void ToProto(const IngestProgressInfo& progress, v1::IngestProgress* out);
void ToProto(const IngestSummaryInfo& summary, v1::IngestSummary* out);

}  // namespace semmap
