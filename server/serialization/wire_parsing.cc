#include "server/serialization/wire_parsing.h"

#include <google/protobuf/unknown_field_set.h>
#include <grpcpp/impl/codegen/proto_utils.h>
#include <grpcpp/support/proto_buffer_reader.h>

#include <climits>
#include <vector>

namespace semmap {
namespace {

std::string Flatten(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (buffer.Dump(&slices).ok()) {
    for (const grpc::Slice& slice : slices) {
      bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
    }
  }
  return bytes;
}

Status NotValid(std::string_view what, std::string_view bytes,
                const google::protobuf::Message& type) {
  return InvalidArgumentError(std::string(what) + " (" + std::to_string(bytes.size()) +
                              " bytes) is not a valid " + type.GetTypeName() + ": " +
                              WireParseFailureReason(bytes));
}

}  // namespace

std::string WireParseFailureReason(std::string_view bytes) {
  google::protobuf::UnknownFieldSet fields;
  if (bytes.size() > INT_MAX ||
      !fields.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    return "the bytes are not protobuf wire data (garbage, or a truncated message)";
  }
  return "the wire data does not decode as its fields (invalid UTF-8 in a string field, a field "
         "of the wrong type, or a nested message that is truncated or garbage)";
}

Status ParseWire(const grpc::ByteBuffer& buffer, google::protobuf::Message* out,
                 std::string_view what) {
  grpc::ByteBuffer copy(buffer);  // shares the slices; the reader needs a mutable buffer
  {
    grpc::ProtoBufferReader reader(&copy);
    if (out->ParseFromZeroCopyStream(&reader)) return OkStatus();
  }
  return NotValid(what, Flatten(buffer), *out);
}

Status ParseWire(std::string_view bytes, google::protobuf::Message* out, std::string_view what) {
  if (bytes.size() <= INT_MAX &&
      out->ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    return OkStatus();
  }
  return NotValid(what, bytes, *out);
}

Status SerializeWire(const google::protobuf::Message& message, grpc::ByteBuffer* out) {
  bool own_buffer = false;
  const grpc::Status status =
      grpc::SerializationTraits<google::protobuf::Message>::Serialize(message, out, &own_buffer);
  if (!status.ok())
    return InternalError("a response failed to serialise: " + status.error_message());
  return OkStatus();
}

}  // namespace semmap
