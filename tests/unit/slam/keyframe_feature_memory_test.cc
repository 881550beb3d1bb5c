#include "core/slam/keyframe_feature_memory.h"

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/slam/feature_codec.h"

namespace semmap {
namespace {

// `n` keypoints whose descriptors all hold `tag`, so a read-back keyframe shows whose it is.
std::shared_ptr<const FrameFeatures> Features(int n, uint8_t tag) {
  FrameFeatures f;
  for (int i = 0; i < n; ++i) {
    f.keypoints.emplace_back(static_cast<float>(i), 2.0f, 31.0f);
    f.points_camera.emplace_back(0, 0, 1);
    f.has_depth.push_back(true);
  }
  f.descriptors = cv::Mat(n, 32, CV_8U, cv::Scalar(tag));
  return std::make_shared<const FrameFeatures>(std::move(f));
}

// A graph of `count` keyframes of session 1 (seq = node), and the store the reader serves
// their features from; `reads` counts the keys asked for.
struct Fixture {
  explicit Fixture(int count) {
    for (int i = 0; i < count; ++i) {
      GraphKeyframe kf;
      kf.session_id = 1;
      kf.seq = i;
      kf.index_in_session = i;
      kf.features = Features(100, static_cast<uint8_t>(i));
      stored[i] = EncodeFeatures(*kf.features);
      graph.Add(std::move(kf));
    }
  }
  KeyframeFeatureMemory::Reader Reader() {
    return [this](const std::vector<std::pair<int64_t, int64_t>>& keys) {
      ++calls;
      std::vector<StatusOr<KeyframeRecord>> out;
      for (const auto& [session, seq] : keys) {
        ++reads;
        const auto it = stored.find(seq);
        if (it == stored.end()) {
          out.emplace_back(NotFoundError("no keyframe"));
          continue;
        }
        KeyframeRecord record;
        record.session_id = session;
        record.seq = seq;
        record.features_format = std::string(kFeatureCodecFormat);
        record.features = it->second;
        out.emplace_back(std::move(record));
      }
      return out;
    };
  }
  // Every keyframe added to `memory` in node order, then trimmed.
  void AddAllAndTrim(KeyframeFeatureMemory& memory) {
    for (int n = 0; n < graph.size(); ++n) memory.Added(n);
    memory.Trim(graph);
  }
  size_t OneKeyframe() const { return graph.node(0).features->HeldBytes(); }
  bool Resident(int n) const { return graph.node(n).features != nullptr; }

  KeyframeGraph graph;
  std::map<int64_t, std::string> stored;
  int calls = 0, reads = 0;
};

TEST(KeyframeFeatureMemoryTest, ReleasesTheLeastRecentlyUsedBeyondTheBudget) {
  Fixture f(5);
  KeyframeFeatureMemory memory(3 * f.OneKeyframe(), f.Reader());
  for (int n = 0; n < 5; ++n) memory.Added(n);
  ASSERT_TRUE(memory.Use(f.graph, {0}).empty());  // 0 is now more recent than 1..4
  memory.Trim(f.graph);
  EXPECT_TRUE(f.Resident(0));
  EXPECT_FALSE(f.Resident(1));
  EXPECT_FALSE(f.Resident(2));
  EXPECT_TRUE(f.Resident(3));
  EXPECT_TRUE(f.Resident(4));
  EXPECT_EQ(memory.released(), 2u);
  EXPECT_EQ(memory.HeldBytes(f.graph), 3 * f.OneKeyframe());
  EXPECT_EQ(f.reads, 0);  // nothing was read: all were resident when used
}

TEST(KeyframeFeatureMemoryTest, ReadsReleasedFeaturesBackInOneCall) {
  Fixture f(4);
  KeyframeFeatureMemory memory(1, f.Reader());
  f.AddAllAndTrim(memory);
  for (int n = 0; n < 4; ++n) EXPECT_FALSE(f.Resident(n));
  EXPECT_TRUE(memory.Use(f.graph, {2, 0, 2}).empty());
  EXPECT_EQ(f.calls, 1);
  EXPECT_EQ(f.reads, 2);
  ASSERT_TRUE(f.Resident(0));
  ASSERT_TRUE(f.Resident(2));
  EXPECT_FALSE(f.Resident(1));
  EXPECT_EQ(f.graph.node(2).features->descriptors.at<uint8_t>(7, 3), 2);
  EXPECT_EQ(f.graph.node(0).features->size(), 100u);
  EXPECT_EQ(memory.read_back(), 2u);
}

TEST(KeyframeFeatureMemoryTest, UnreadableKeyframesAreReportedNotResident) {
  Fixture f(3);
  f.stored.erase(1);        // never stored (a failed write)
  f.stored[2] = "damaged";  // does not decode
  KeyframeFeatureMemory memory(1, f.Reader());
  f.AddAllAndTrim(memory);
  const std::vector<std::pair<int, Status>> failed = memory.Use(f.graph, {0, 1, 2});
  ASSERT_EQ(failed.size(), 2u);
  EXPECT_EQ(failed[0].first, 1);
  EXPECT_EQ(failed[0].second.code(), StatusCode::kNotFound);
  EXPECT_NE(failed[0].second.message().find("keyframe seq 1 of session 1"), std::string::npos)
      << failed[0].second.ToString();
  EXPECT_EQ(failed[1].first, 2);
  EXPECT_FALSE(failed[1].second.ok());
  EXPECT_TRUE(f.Resident(0));
  EXPECT_FALSE(f.Resident(1));
  EXPECT_FALSE(f.Resident(2));
  EXPECT_EQ(memory.unreadable(), 2u);
}

TEST(KeyframeFeatureMemoryTest, ZeroBudgetKeepsEverythingAndCulledKeyframesAreLeftAlone) {
  Fixture f(3);
  KeyframeFeatureMemory unlimited(0, f.Reader());
  f.AddAllAndTrim(unlimited);
  for (int n = 0; n < 3; ++n) EXPECT_TRUE(f.Resident(n));

  f.graph.Cull(1);
  KeyframeFeatureMemory memory(1, nullptr);  // no store: reading back fails
  memory.Trim(f.graph);
  EXPECT_EQ(memory.released(), 2u);               // the two kept ones
  EXPECT_TRUE(memory.Use(f.graph, {1}).empty());  // culled: nothing to give
  const auto failed = memory.Use(f.graph, {0});
  ASSERT_EQ(failed.size(), 1u);
  EXPECT_EQ(failed[0].second.code(), StatusCode::kFailedPrecondition);
  f.graph.SetFeatures(1, Features(1, 9));  // a culled keyframe takes none
  EXPECT_FALSE(f.Resident(1));
}

}  // namespace
}  // namespace semmap
