// Wire bytes -> domain messages at the service edge: parse failures named, stamps range-checked.
#include <gtest/gtest.h>

#include <limits>
#include <variant>

#include "server/serialization/conversions.h"
#include "server/serialization/ingest_conversions.h"
#include "server/serialization/wire_parsing.h"

namespace semmap {
namespace {

TEST(WireConversionsTest, StampsAtTheEdgesOfInt64Nanoseconds) {
  google::protobuf::Timestamp t;
  t.set_seconds(1'341'841'873);
  t.set_nanos(541'941'000);
  EXPECT_EQ(StampNsFromProto(t).value(), 1'341'841'873'541'941'000);
  const int64_t max_seconds = std::numeric_limits<int64_t>::max() / 1'000'000'000 - 1;
  t.set_seconds(max_seconds);
  t.set_nanos(999'999'999);
  EXPECT_TRUE(StampNsFromProto(t).ok());
  t.set_seconds(max_seconds + 1);
  EXPECT_EQ(StampNsFromProto(t).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(FromProto(t), std::numeric_limits<int64_t>::max());  // clamped, not UB
  t.set_seconds(-max_seconds);
  t.set_nanos(0);
  EXPECT_TRUE(StampNsFromProto(t).ok());
  t.set_seconds(std::numeric_limits<int64_t>::min());
  EXPECT_EQ(StampNsFromProto(t).status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(FromProto(t), std::numeric_limits<int64_t>::min());
  t.set_seconds(0);
  t.set_nanos(1'000'000'000);
  EXPECT_EQ(StampNsFromProto(t).status().code(), StatusCode::kInvalidArgument);
}

TEST(WireConversionsTest, UnparseableIngestMessagesAreNamed) {
  for (const std::string& bytes : {std::string("\xff\xff\xff\xff\x0f", 5),
                                   std::string("\x12\x20\x08\x01", 4)}) {  // garbage, truncated
    const IngestMessage message = ParseIngestRequest(bytes, 7);
    const auto* invalid = std::get_if<IngestInvalid>(&message);
    ASSERT_NE(invalid, nullptr);
    EXPECT_EQ(invalid->status.code(), StatusCode::kInvalidArgument);
    EXPECT_NE(invalid->status.message().find("message 7 of the ingest stream (" +
                                             std::to_string(bytes.size()) +
                                             " bytes) is not a valid semmap.v1.IngestRequest"),
              std::string::npos)
        << invalid->status.message();
    EXPECT_NE(invalid->status.message().find("not protobuf wire data"), std::string::npos);
  }
  // Well-formed wire data whose string field is not UTF-8.
  v1::IngestRequest start;
  start.mutable_start()->set_map("m\xc3\x28");
  std::string bytes;
  ASSERT_TRUE(start.SerializeToString(&bytes));
  const IngestMessage message = ParseIngestRequest(bytes, 1);
  const auto* invalid = std::get_if<IngestInvalid>(&message);
  ASSERT_NE(invalid, nullptr);
  EXPECT_NE(invalid->status.message().find("invalid UTF-8 in a string field"), std::string::npos)
      << invalid->status.message();
  // An empty message is a valid, empty IngestRequest: named as such.
  const IngestMessage empty = ParseIngestRequest(std::string(), 2);
  ASSERT_TRUE(std::holds_alternative<IngestInvalid>(empty));
  EXPECT_NE(std::get<IngestInvalid>(empty).status.message().find("empty ingest message"),
            std::string::npos);
}

TEST(WireConversionsTest, OutOfRangeFrameStampIsInvalid) {
  v1::IngestRequest request;
  request.mutable_frame()->set_seq(4);
  request.mutable_frame()->mutable_timestamp()->set_seconds(std::numeric_limits<int64_t>::max());
  const IngestMessage message = FromProto(std::move(request));
  const auto* invalid = std::get_if<IngestInvalid>(&message);
  ASSERT_NE(invalid, nullptr);
  EXPECT_NE(invalid->status.message().find("frame seq 4: timestamp"), std::string::npos)
      << invalid->status.message();
}

}  // namespace
}  // namespace semmap
