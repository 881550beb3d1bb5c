// KeyframeCloudCache over a real SQLite store with small keyframes: eviction beyond the budget
// takes the oldest stored clouds down to 3/4 of it, never one the store does not hold, and a
// cloud read back equals the one made from the live images.
#include "core/mapping/keyframe_cloud_cache.h"

#include <gtest/gtest.h>

#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "tests/testing/pinhole_camera.h"
#include "tests/testing/test_store.h"

namespace semmap {
namespace {

constexpr double kDepthScale = 5000;

CameraCalibration SmallCamera() { return testing::PinholeCamera(32, 24, 30, 16, 12); }

// A slanted wall 1-1.5 m away, coloured by position, different for each seq.
struct Images {
  cv::Mat depth, bgr;
};
Images ImagesFor(int64_t seq) {
  Images out{cv::Mat(24, 32, CV_16UC1), cv::Mat(24, 32, CV_8UC3)};
  for (int y = 0; y < 24; ++y) {
    for (int x = 0; x < 32; ++x) {
      out.depth.at<uint16_t>(y, x) = static_cast<uint16_t>(5000 + 100 * x + 10 * seq);
      out.bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(
          static_cast<uint8_t>(8 * x), static_cast<uint8_t>(10 * y), static_cast<uint8_t>(seq));
    }
  }
  return out;
}

class KeyframeCloudCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    StatusOr<std::unique_ptr<testing::TestStore>> store =
        testing::MakeTestStore("room", "lap", SmallCamera(), kDepthScale);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    store_ = std::move(store).value();
    options_.pixel_step = 1;
  }

  std::shared_ptr<const KeyframeCloud> LiveCloud(int64_t seq) const {
    const Images images = ImagesFor(seq);
    StatusOr<KeyframeCloud> cloud =
        MakeKeyframeCloud({images.depth, kDepthScale}, images.bgr, SmallCamera(), options_);
    EXPECT_TRUE(cloud.ok()) << cloud.status().ToString();
    return std::make_shared<const KeyframeCloud>(std::move(cloud).value());
  }

  void Store(const std::vector<int64_t>& seqs) {
    WriteBatch batch;
    for (int64_t seq : seqs) {
      const Images images = ImagesFor(seq);
      KeyframeRecord record;
      record.session_id = store_->session.id;
      record.seq = seq;
      std::vector<uint8_t> bytes;
      cv::imencode(".png", images.bgr, bytes);
      record.colour = {"png", std::string(bytes.begin(), bytes.end())};
      cv::imencode(".png", images.depth, bytes);
      record.depth = {"png", std::string(bytes.begin(), bytes.end())};
      record.depth_scale = kDepthScale;
      batch.keyframes.push_back(std::move(record));
    }
    ASSERT_TRUE(
        store_->writer->RunSync([&](MapStore& store) { return store.Write(batch).status(); }).ok());
  }

  KeyframeCloudCache MakeCache(size_t budget_bytes) {
    return KeyframeCloudCache(
        budget_bytes, options_,
        [this](const std::function<Status(MapStore&)>& read) { return read(*store_->read); });
  }

  KeyframeCloudCache::Key Key(int64_t seq) const { return {store_->session.id, seq}; }

  std::unique_ptr<testing::TestStore> store_;
  OccupancyMapOptions options_;
};

TEST_F(KeyframeCloudCacheTest, EvictsTheOldestStoredCloudsDownToThreeQuartersOfTheBudget) {
  const size_t each = KeyframeCloudCache::BytesOf(*LiveCloud(0));
  KeyframeCloudCache cache = MakeCache(4 * each);
  for (int64_t seq = 0; seq < 6; ++seq) cache.Put(Key(seq), LiveCloud(seq), SmallCamera());
  EXPECT_EQ(cache.resident_bytes(), 6 * each);

  // Nothing stored yet: every cloud stays.
  ASSERT_TRUE(cache.EvictOverBudget().ok());
  EXPECT_EQ(cache.evicted(), 0u);

  // Keyframe 0 is still not stored (its write failed, say): it stays in memory and does not hold
  // up the others; the oldest stored ones go until 3 (<= 3/4 of 4) are left.
  Store({1, 2, 3, 4, 5});
  ASSERT_TRUE(cache.EvictOverBudget().ok());
  EXPECT_EQ(cache.evicted(), 3u);
  EXPECT_EQ(cache.resident_bytes(), 3 * each);
  for (int64_t seq : {0, 4, 5}) EXPECT_NE(cache.SourceOf(Key(seq)).cloud, nullptr) << seq;
  for (int64_t seq : {1, 2, 3}) EXPECT_EQ(cache.SourceOf(Key(seq)).cloud, nullptr) << seq;
  // Within budget: nothing more goes.
  ASSERT_TRUE(cache.EvictOverBudget().ok());
  EXPECT_EQ(cache.evicted(), 3u);

  // Read back: the same points and colours as the live images gave; not kept unless asked.
  const std::shared_ptr<const KeyframeCloud> live = LiveCloud(2);
  StatusOr<std::shared_ptr<const KeyframeCloud>> read = cache.Read(cache.SourceOf(Key(2)));
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ((*read)->points, live->points);
  EXPECT_EQ((*read)->colours, live->colours);
  EXPECT_EQ(cache.reads(), 1u);
  EXPECT_EQ(cache.SourceOf(Key(2)).cloud, nullptr);
  cache.KeepIfRoom(Key(2), *read);  // 3 + 1 <= 4
  EXPECT_EQ(cache.SourceOf(Key(2)).cloud, *read);
  cache.KeepIfRoom(Key(3), *read);  // 5 > 4: stays in the store
  EXPECT_EQ(cache.SourceOf(Key(3)).cloud, nullptr);
  EXPECT_EQ(cache.resident_bytes(), 4 * each);

  // Over budget again (a new keyframe 6, stored): the hook sees each cloud before it goes, except
  // the one read back from the store; one it refuses stays and goes to the back of the queue.
  Store({6});
  cache.Put(Key(6), LiveCloud(6), SmallCamera());
  std::vector<int64_t> asked;
  ASSERT_TRUE(cache
                  .EvictOverBudget([&](const KeyframeCloudCache::Key& key,
                                       const std::shared_ptr<const KeyframeCloud>& in_memory,
                                       const KeyframeCloudCache::Source& stored) {
                    EXPECT_NE(in_memory, nullptr);
                    EXPECT_EQ(stored.cloud, nullptr);
                    EXPECT_GT(stored.keyframe_id, 0);
                    asked.push_back(key.second);
                    return key.second != 4;  // 4 cannot be read back, say
                  })
                  .ok());
  // In memory, oldest first: 4, 5, 0 (not stored: moved back), 2 (read back), 6. Down to 3 of 5:
  // 4 refused, 5 goes, 0 stays, 2 goes unasked.
  EXPECT_EQ(asked, (std::vector<int64_t>{4, 5}));
  for (int64_t seq : {0, 4, 6}) EXPECT_NE(cache.SourceOf(Key(seq)).cloud, nullptr) << seq;
  for (int64_t seq : {2, 5}) EXPECT_EQ(cache.SourceOf(Key(seq)).cloud, nullptr) << seq;
  EXPECT_EQ(cache.resident_bytes(), 3 * each);

  // New images for an evicted keyframe put it back in memory, unconfirmed by the store.
  cache.Put(Key(1), LiveCloud(1), SmallCamera());
  EXPECT_EQ(cache.evicted(), 3u);  // 2, 3, 5
  cache.Erase(Key(3));
  EXPECT_FALSE(cache.Contains(Key(3)));
  EXPECT_EQ(cache.evicted(), 2u);
}

TEST_F(KeyframeCloudCacheTest, RestoredKeyframesAreReadWhenNeededAndMissingOnesAreNotFound) {
  Store({7});
  StatusOr<std::vector<KeyframeRecord>> records =
      store_->read->ListKeyframes(store_->session.id, /*with_images=*/false);
  ASSERT_TRUE(records.ok() && records->size() == 1u);
  KeyframeCloudCache cache = MakeCache(0);
  cache.PutStored(Key(7), records->front().id, SmallCamera());
  cache.PutStored(Key(8), records->front().id + 100, SmallCamera());  // not in the store
  EXPECT_EQ(cache.resident_bytes(), 0u);
  EXPECT_EQ(cache.evicted(), 2u);
  StatusOr<std::shared_ptr<const KeyframeCloud>> read = cache.Read(cache.SourceOf(Key(7)));
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ((*read)->points, LiveCloud(7)->points);
  EXPECT_EQ(cache.Read(cache.SourceOf(Key(8))).status().code(), StatusCode::kNotFound);
  cache.KeepIfRoom(Key(7), *read);  // a budget of 0 keeps nothing
  EXPECT_EQ(cache.resident_bytes(), 0u);
}

}  // namespace
}  // namespace semmap
