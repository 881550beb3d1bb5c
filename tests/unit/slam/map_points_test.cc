#include "core/slam/map_points.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace semmap {
namespace {

// n keypoints; keypoint k has depth (a point 2 m ahead) unless k is in `no_depth`.
FrameFeatures Features(int n, std::vector<int> no_depth = {}) {
  FrameFeatures f;
  for (int k = 0; k < n; ++k) {
    f.keypoints.emplace_back(static_cast<float>(10 * k), 5.0f, 31.0f);
    const bool depth = std::find(no_depth.begin(), no_depth.end(), k) == no_depth.end();
    f.points_camera.emplace_back(0.1 * k, 0, depth ? 2.0 : 0.0);
    f.has_depth.push_back(depth);
  }
  f.descriptors = cv::Mat::zeros(n, 32, CV_8U);
  return f;
}

// A point needs a second keyframe's confirmation, judged two keyframes after its creator.
MapPointsOptions JudgedAfterTwoKeyframes() {
  MapPointsOptions options;
  options.min_observations = 2;
  options.cull_age_keyframes = 2;
  return options;
}

Eigen::Isometry3d At(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation().x() = x;
  return T;
}

TEST(MapPointsTest, KeyframesCreateAndObservePointsByTrackerId) {
  MapPoints points;
  const FrameFeatures f = Features(4, /*no_depth=*/{3});
  // Keyframe 0 starts points 10, 11, 12 (13 has no depth: nothing to place it by).
  EXPECT_EQ(points.AddKeyframe(1, 0, 0, f, At(1), {10, 11, 12, 13}), 3);
  ASSERT_EQ(points.size(), 3u);
  // Keyframe 1 sees 11 and 12 again (12 twice: the second is ignored) and starts 20.
  EXPECT_EQ(points.AddKeyframe(1, 1, 1, f, At(5), {11, 12, 12, 20}), 2);
  EXPECT_EQ(points.size(), 3u);  // 20 would need depth at keypoint 3
  EXPECT_EQ(points.num_observations(), 5u);
  const std::vector<int64_t>& of_1 = points.PointsOf(1);
  ASSERT_EQ(of_1.size(), 2u);
  const MapPointState* p = points.Find(of_1[0]);
  ASSERT_NE(p, nullptr);
  EXPECT_EQ(p->tracker_id, 11);
  // Placed by its first keyframe: T_world_keyframe * points_camera.
  EXPECT_TRUE(p->position_world.isApprox(Eigen::Vector3d(1.1, 0, 2)));
  ASSERT_EQ(p->observations.size(), 2u);
  EXPECT_EQ(p->observations[1].keyframe, 1);
  EXPECT_EQ(p->observations[1].keypoint, 0);
  // The same tracker id in another session is another point.
  EXPECT_EQ(points.AddKeyframe(2, 2, 0, f, At(0), {11, -1, -1, -1}), 1);
  EXPECT_EQ(points.size(), 4u);
  EXPECT_TRUE(points.PointsOf(7).empty());
}

// A restarted server's points: restored with their observations, unknown to every tracker
// until a session is given one (under a foreign id), whose keyframes then observe it.
TEST(MapPointsTest, RestoredPointsAreObservedByLaterSessionsUnderForeignIds) {
  MapPoints points;
  const FrameFeatures f = Features(4);
  // Observations in any order, one per keyframe kept, negative keyframes dropped.
  const int64_t a =
      points.Restore(/*session_id=*/1, Eigen::Vector3d(1, 2, 3), {{2, 1}, {0, 3}, {2, 0}, {-1, 0}});
  ASSERT_GE(a, 0);
  EXPECT_EQ(points.Restore(1, Eigen::Vector3d::Zero(), {}), -1);
  const MapPointState* p = points.Find(a);
  ASSERT_NE(p, nullptr);
  ASSERT_EQ(p->observations.size(), 2u);
  EXPECT_EQ(p->observations[0].keyframe, 0);
  EXPECT_EQ(p->observations[1].keyframe, 2);
  EXPECT_EQ(points.num_observations(), 2u);
  EXPECT_EQ(points.PointsOf(2), std::vector<int64_t>{a});
  EXPECT_EQ(points.Covisible(0), (std::vector<std::pair<int, int>>{{2, 1}}));

  // Session 5's tracker is told of the point under a foreign id (the same one every time).
  const int64_t foreign = points.TrackerIdFor(5, a);
  EXPECT_EQ(foreign, MapPoints::kForeignTrackerIdBase + a);
  EXPECT_EQ(points.TrackerIdFor(5, a), foreign);
  EXPECT_EQ(points.TrackerIdFor(5, a + 100), -1);
  // Its keyframe matching that id observes the restored point instead of starting a new one.
  EXPECT_EQ(points.AddKeyframe(5, 3, 0, f, At(0), {foreign, 0, -1, -1}), 2);
  EXPECT_EQ(points.size(), 2u);
  ASSERT_EQ(p->observations.size(), 3u);
  EXPECT_EQ(p->observations[2].keyframe, 3);
  // A point a session created keeps the tracker id it was created under.
  const int64_t own = points.PointsOf(3)[1];
  EXPECT_EQ(points.TrackerIdFor(5, own), 0);
  int visited = 0;
  points.ForEach([&](const MapPointState&) { ++visited; });
  EXPECT_EQ(visited, 2);
}

// A map revisited every day: each session is told of the map's points under foreign names,
// which the map does not store per session (it would grow with every visit). A foreign name
// still finds its point after that point was fused into another.
TEST(MapPointsTest, ForeignNamesCostNothingAndFollowFusion) {
  MapPoints points;
  const FrameFeatures f = Features(4);
  points.AddKeyframe(1, 0, 0, f, At(0), {0, 1, 2, 3});
  const int64_t a = points.PointsOf(0)[0], b = points.PointsOf(0)[1];
  const size_t held = points.HeldBytes();
  for (int64_t session = 10; session < 110; ++session) {
    EXPECT_EQ(points.TrackerIdFor(session, a), MapPoints::kForeignTrackerIdBase + a);
  }
  EXPECT_EQ(points.HeldBytes(), held);
  // a is fused into b: session 10's keyframe naming a by its foreign name observes b.
  ASSERT_TRUE(points.Fuse(b, a));
  EXPECT_EQ(points.AddKeyframe(10, 1, 0, f, At(0),
                               {MapPoints::kForeignTrackerIdBase + a, -1, -1,
                                MapPoints::kForeignTrackerIdBase + 999}),
            2);
  ASSERT_EQ(points.PointsOf(1).size(), 2u);
  EXPECT_EQ(points.PointsOf(1)[0], b);
  // A name no point answers to (e.g. of a culled point) starts one, as any unknown name does.
  const MapPointState* started = points.Find(points.PointsOf(1)[1]);
  ASSERT_NE(started, nullptr);
  EXPECT_EQ(started->session_id, 10);
  EXPECT_EQ(points.size(), 4u);
}

TEST(MapPointsTest, CovisibilityAndTheLocalWindow) {
  MapPoints points;
  const FrameFeatures f = Features(6);
  points.AddKeyframe(1, 0, 0, f, At(0), {0, 1, 2, 3, 4, 5});
  points.AddKeyframe(1, 1, 1, f, At(0), {0, 1, 2, 3, -1, -1});
  points.AddKeyframe(1, 2, 2, f, At(0), {2, 3, 6, 7, 8, -1});
  points.AddKeyframe(1, 3, 3, f, At(0), {7, 8, 9, -1, -1, -1});
  const auto covisible = points.Covisible(2);
  ASSERT_EQ(covisible.size(), 3u);
  EXPECT_EQ(covisible[0].second, 2);  // keyframes 0 and 1 share 2, 3; keyframe 3 shares 7, 8
  const BundleAdjustmentWindow window = points.LocalWindow(3, /*max_free=*/2, /*max_fixed=*/1);
  EXPECT_EQ(window.free_keyframes, (std::vector<int>{2, 3}));
  // Points of the free keyframes: 2, 3, 6, 7, 8, 9; keyframes 0 and 1 both see 2 and 3: one
  // of them is kept as fixed.
  EXPECT_EQ(window.points.size(), 6u);
  ASSERT_EQ(window.fixed_keyframes.size(), 1u);
  EXPECT_LE(window.fixed_keyframes[0], 1);
}

TEST(MapPointsTest, CullingRemovesPointsTooFewKeyframesConfirm) {
  MapPoints points(JudgedAfterTwoKeyframes());
  const FrameFeatures f = Features(3);
  points.AddKeyframe(1, 0, 0, f, At(0), {0, 1, 2});
  points.AddKeyframe(1, 1, 1, f, At(0), {0, -1, -1});
  EXPECT_EQ(points.Cull(1, 1), 0);  // too young to judge
  points.AddKeyframe(1, 2, 2, f, At(0), {0, 1, -1});
  EXPECT_EQ(points.Cull(1, 2), 1);  // point 2: only its creator saw it
  EXPECT_EQ(points.size(), 2u);
  EXPECT_EQ(points.PointsOf(0).size(), 2u);
  EXPECT_EQ(points.Cull(1, 5), 0);  // judged once: kept for good
  // A removed observation; a point left with none is gone.
  const int64_t id = points.PointsOf(1)[0];
  points.RemoveObservation(id, 0);
  points.RemoveObservation(id, 1);
  ASSERT_NE(points.Find(id), nullptr);
  points.RemoveObservation(id, 2);
  EXPECT_EQ(points.Find(id), nullptr);
  EXPECT_EQ(points.size(), 1u);
  EXPECT_EQ(points.num_observations(), 2u);
}

// A session that ends before its last keyframes' points are judged leaves them to later
// sessions: kept until enough later keyframes look at that place, then judged as usual.
TEST(MapPointsTest, AnEndedSessionsYoungPointsAreJudgedByLaterLooksAtTheirPlace) {
  MapPoints points(JudgedAfterTwoKeyframes());
  const FrameFeatures f = Features(3);
  points.AddKeyframe(1, 0, 0, f, At(0), {0, 1, 2});  // session 1's last keyframe
  const std::vector<int64_t> young = points.PointsOf(0);
  ASSERT_EQ(young.size(), 3u);
  points.EndSession(1);
  EXPECT_EQ(points.Cull(1, 10), 0);  // no longer the session's to judge
  EXPECT_EQ(points.size(), 3u);
  // Session 2 somewhere else: shares no point with keyframe 0, so it is no look there.
  points.AddKeyframe(2, 1, 0, f, At(5), {0, 1, 2});
  EXPECT_EQ(points.JudgeAround(1), 0);
  // Session 2 back at keyframe 0's place, matching the first young point: one look.
  const auto foreign = [&](int64_t id) { return points.TrackerIdFor(2, id); };
  points.AddKeyframe(2, 2, 1, f, At(0), {foreign(young[0]), -1, -1});
  EXPECT_EQ(points.JudgeAround(2), 0);  // looked at once: too few to judge
  EXPECT_EQ(points.size(), 6u);
  // A second look, which also confirms the second point: the third, seen by its creator only,
  // goes; the confirmed ones stay.
  points.AddKeyframe(2, 3, 2, f, At(0), {foreign(young[0]), foreign(young[1]), -1});
  EXPECT_EQ(points.JudgeAround(3), 1);
  EXPECT_NE(points.Find(young[0]), nullptr);
  EXPECT_NE(points.Find(young[1]), nullptr);
  EXPECT_EQ(points.Find(young[2]), nullptr);
  // Judged once: later looks remove nothing.
  points.AddKeyframe(2, 4, 3, f, At(0), {foreign(young[0]), -1, -1});
  EXPECT_EQ(points.JudgeAround(4), 0);
  EXPECT_EQ(points.size(), 5u);
}

// A map read back from the store (a restarted server, or a map whose idle pipeline was
// released) has no session to judge its unconfirmed points: they wait for looks like an ended
// session's.
TEST(MapPointsTest, RestoredUnconfirmedPointsAreJudgedByLaterLooks) {
  MapPoints points(JudgedAfterTwoKeyframes());
  const FrameFeatures f = Features(3);
  const int64_t confirmed = points.Restore(1, Eigen::Vector3d(0, 0, 2), {{0, 0}, {1, 0}});
  const int64_t lone = points.Restore(1, Eigen::Vector3d(0.1, 0, 2), {{0, 1}});
  ASSERT_GE(lone, 0);
  for (int k = 2; k <= 3; ++k) {
    points.AddKeyframe(2, k, k - 2, f, At(0), {points.TrackerIdFor(2, confirmed), -1, -1});
  }
  EXPECT_EQ(points.JudgeAround(2), 0);
  EXPECT_EQ(points.JudgeAround(3), 1);
  EXPECT_EQ(points.Find(lone), nullptr);
  EXPECT_NE(points.Find(confirmed), nullptr);
}

TEST(MapPointsTest, PointsMoveWithTheirOldestKeyframe) {
  MapPoints points;
  const FrameFeatures f = Features(2);
  points.AddKeyframe(1, 0, 0, f, At(0), {0, -1});
  points.AddKeyframe(1, 1, 1, f, At(1), {0, 1});
  const int64_t first = points.PointsOf(0)[0], second = points.PointsOf(1)[1];
  points.MoveWithKeyframes({{1, At(0.5)}});  // keyframe 1 moved by 0.5 m
  EXPECT_TRUE(points.Find(first)->position_world.isApprox(Eigen::Vector3d(0, 0, 2)));
  EXPECT_TRUE(points.Find(second)->position_world.isApprox(Eigen::Vector3d(1.6, 0, 2)));
}

TEST(MapPointsTest, FusedPointsMergeObservationsAndAnswerToBothTrackerIds) {
  MapPoints points;
  const FrameFeatures f = Features(2);
  points.AddKeyframe(1, 0, 0, f, At(0), {10, 11});  // the place, first visit
  points.AddKeyframe(1, 1, 1, f, At(0), {10, -1});
  points.AddKeyframe(1, 2, 2, f, At(0), {20, 21});  // back again: new ids for the same points
  const auto first = points.PointsByKeypoint(0), again = points.PointsByKeypoint(2);
  ASSERT_EQ(first.size(), 2u);
  ASSERT_EQ(again.size(), 2u);
  EXPECT_FALSE(points.Fuse(first.at(0), first.at(0)));
  EXPECT_FALSE(points.Fuse(first.at(0), 12345));
  ASSERT_TRUE(points.Fuse(/*keep=*/first.at(0), /*drop=*/again.at(0)));
  EXPECT_EQ(points.size(), 3u);
  EXPECT_EQ(points.Find(again.at(0)), nullptr);
  const MapPointState* kept = points.Find(first.at(0));
  ASSERT_EQ(kept->observations.size(), 3u);  // keyframes 0, 1 and 2
  EXPECT_EQ(points.PointsByKeypoint(2).at(0), first.at(0));
  EXPECT_EQ(points.Covisible(2).size(), 2u);  // the loop is now covisibility
  // The tracker's later observation under the dropped id lands on the kept point.
  points.AddKeyframe(1, 3, 3, f, At(0), {20, -1});
  EXPECT_EQ(points.Find(first.at(0))->observations.size(), 4u);
  EXPECT_EQ(points.size(), 3u);
  EXPECT_EQ(points.num_observations(), 6u);
}

TEST(MapPointsTest, OptionsAreValidated) {
  MapPointsOptions options;
  EXPECT_TRUE(options.Validate().ok());
  options.min_observations = 0;
  EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument);
  options = {};
  options.cull_age_keyframes = 0;
  EXPECT_EQ(options.Validate().code(), StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace semmap
