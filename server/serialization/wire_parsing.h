// Request bytes off the wire -> protobuf messages, with errors a client can act on. Every method
// of the service is registered raw (byte buffers) and parses here, because gRPC's own parsing
// answers a request that does not parse with UNIMPLEMENTED and no message (unary calls) or takes
// it for the client's half-close (streams, which would end OK and drop what followed).
#pragma once

#include <google/protobuf/message.h>
#include <grpcpp/support/byte_buffer.h>

#include <string>
#include <string_view>

#include "common/status.h"

namespace semmap {

// Why bytes did not parse, as far as the wire format tells (garbage or truncation, or fields
// that do not decode: invalid UTF-8 in a string, a wrong wire type, a broken nested message).
std::string WireParseFailureReason(std::string_view bytes);

// Parses `buffer` into `out`; INVALID_ARGUMENT "<what> (N bytes) is not a valid <type>: <why>".
Status ParseWire(const grpc::ByteBuffer& buffer, google::protobuf::Message* out,
                 std::string_view what);
Status ParseWire(std::string_view bytes, google::protobuf::Message* out, std::string_view what);

// INTERNAL only for a message over 2 GiB (ours are bounded far below).
Status SerializeWire(const google::protobuf::Message& message, grpc::ByteBuffer* out);

}  // namespace semmap
