// The map point observations blob: exact layout, round trip, and what the decoder refuses.
#include "storage/sqlite/map_point_codec.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "tests/unit/storage/storage_test_util.h"

namespace semmap::sqlite {
namespace {

MapPointObservationRecord Seen(int64_t session_id, int64_t seq, int32_t keypoint) {
  MapPointObservationRecord o;
  o.session_id = session_id;
  o.seq = seq;
  o.keypoint = keypoint;
  return o;
}

void ExpectDataLoss(const std::string& bytes, const std::string& detail) {
  auto decoded = DecodeMapPointObservations(bytes);
  ASSERT_FALSE(decoded.ok());
  EXPECT_EQ(decoded.status().code(), StatusCode::kDataLoss);
  EXPECT_NE(decoded.status().message().find(detail), std::string::npos)
      << decoded.status().message();
}

TEST(MapPointCodecTest, LayoutIsCountThenLittleEndianFields) {
  auto bytes = EncodeMapPointObservations({Seen(0x0102030405060708, 9, 0x0a0b0c0d)});
  ASSERT_OK(bytes.status());
  const std::string expected(
      "\x01\x00\x00\x00"                  // count
      "\x08\x07\x06\x05\x04\x03\x02\x01"  // session_id
      "\x09\x00\x00\x00\x00\x00\x00\x00"  // seq
      "\x0d\x0c\x0b\x0a",                 // keypoint
      24);
  EXPECT_EQ(*bytes, expected);
  EXPECT_EQ(*EncodeMapPointObservations({}), std::string(4, '\0'));
}

TEST(MapPointCodecTest, RoundTripsExtremeValues) {
  const std::vector<MapPointObservationRecord> observations = {
      Seen(1, 0, 0),
      Seen(std::numeric_limits<int64_t>::max(), std::numeric_limits<int64_t>::min(),
           std::numeric_limits<int32_t>::max()),
      Seen(-1, -2, 3),  // no keyframe has them, but they are representable
  };
  auto bytes = EncodeMapPointObservations(observations);
  ASSERT_OK(bytes.status());
  EXPECT_EQ(bytes->size(), kMapPointCountBytes + 3 * kMapPointObservationBytes);
  auto decoded = DecodeMapPointObservations(*bytes);
  ASSERT_OK(decoded.status());
  ASSERT_EQ(decoded->size(), observations.size());
  for (size_t i = 0; i < observations.size(); ++i) {
    EXPECT_EQ((*decoded)[i].session_id, observations[i].session_id) << i;
    EXPECT_EQ((*decoded)[i].seq, observations[i].seq) << i;
    EXPECT_EQ((*decoded)[i].keypoint, observations[i].keypoint) << i;
  }
  EXPECT_TRUE(DecodeMapPointObservations(std::string(4, '\0'))->empty());
}

TEST(MapPointCodecTest, EncodeRefusesANegativeKeypoint) {
  auto bytes = EncodeMapPointObservations({Seen(1, 0, 0), Seen(1, 1, -3)});
  EXPECT_EQ(bytes.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(bytes.status().message().find("observation 1 has keypoint -3"), std::string::npos)
      << bytes.status().message();
}

TEST(MapPointCodecTest, DecodeRefusesWhatEncodeCannotWrite) {
  const std::string two = *EncodeMapPointObservations({Seen(1, 0, 0), Seen(1, 1, 1)});
  ExpectDataLoss("", "fewer than their count needs");
  ExpectDataLoss(two.substr(0, 3), "fewer than their count needs");
  ExpectDataLoss(two.substr(0, two.size() - 1), "count 2 but have 43 bytes");
  ExpectDataLoss(two.substr(0, 24), "count 2 but have 24 bytes");
  ExpectDataLoss(two + std::string(20, '\0'), "count 2 but have 64 bytes");
  ExpectDataLoss('\x01' + two.substr(1), "count 1 but have 44 bytes");
  // A huge count next to a few bytes: refused before anything is sized by it.
  ExpectDataLoss(std::string(4, '\xff') + two.substr(4), "count 4294967295 but have 44 bytes");
  ExpectDataLoss(two.substr(0, 40) + std::string(4, '\x80'), "observation 1 has keypoint");
}

}  // namespace
}  // namespace semmap::sqlite
