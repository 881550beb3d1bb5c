// Wire ingest messages -> pipeline messages (moves the image bytes, no copies) and back.
#pragma once

#include "rpc/conversions.h"
#include "server/ingest/ingest_types.h"

namespace semmap {

// Always yields a message: a request that cannot be converted becomes IngestInvalid.
IngestMessage FromProto(v1::IngestRequest&& request);

void ToProto(const SessionInfo& session, v1::IngestStarted* out);
void ToProto(const FrameAckInfo& ack, v1::FrameAck* out);
void ToProto(const IngestProgressInfo& progress, v1::IngestProgress* out);
void ToProto(const IngestSummaryInfo& summary, v1::IngestSummary* out);

}  // namespace semmap
