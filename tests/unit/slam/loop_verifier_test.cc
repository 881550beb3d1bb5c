#include "core/slam/loop_verifier.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "common/xi_check.h"
#include "tests/testing/synth/texture.h"
#include "tests/testing/units.h"
#include "tests/unit/odometry/odometry_test_util.h"

namespace semmap {
namespace {

using odometry_test::AngleDeg;
using odometry_test::Extract;
using odometry_test::MakeRenderer;

const FeatureExtractor& Extractor() {
  static const FeatureExtractor* const e = [] {
    StatusOr<FeatureExtractor> x = FeatureExtractor::Create({}, synth::DefaultSyntheticCamera());
    if (!x.ok()) std::abort();
    return new FeatureExtractor(std::move(x).value());
  }();
  return *e;
}

FrameFeatures Features(const synth::Renderer& r, const Eigen::Isometry3d& T_world_camera) {
  return Extract(Extractor(), r.Render(T_world_camera));
}

// A camera in the default room at 1.3 m looking along `yaw_deg` (from +x), slightly down.
Eigen::Isometry3d RoomPose(double x, double y, double yaw_deg) {
  return synth::LookingPose({x, y, 1.3}, yaw_deg * kDeg, -0.15);
}

std::vector<const FrameFeatures*> Pointers(const std::vector<FrameFeatures>& f) {
  std::vector<const FrameFeatures*> p;
  p.reserve(f.size());
  for (const FrameFeatures& x : f) p.push_back(&x);
  return p;
}

LoopVerification Verify(const FrameFeatures& query, const FrameFeatures& candidate,
                        const std::vector<FrameFeatures>& neighbours,
                        const LoopVerifierOptions& options = {}) {
  StatusOr<LoopVerification> v = VerifyLoopCandidate(query, candidate, Pointers(neighbours),
                                                     synth::DefaultSyntheticCamera(), options);
  EXPECT_TRUE(v.ok()) << v.status().ToString();
  return v.ok() ? *v : LoopVerification{};
}

// A room of distinct textured walls with two identical posters (one texture) on opposite walls:
// a perceptual alias. Poster A hangs on the -y wall at x = -1, poster B on the +y wall at
// x = +1; both face the room.
struct AliasScene {
  synth::Scene scene;
  synth::Surface poster_a, poster_b;
};

const AliasScene& Alias() {
  static const AliasScene* const alias = [] {
    auto* a = new AliasScene;
    synth::Scene& s = a->scene;
    s.room = Eigen::AlignedBox3d(Eigen::Vector3d(-3, -2.5, 0), Eigen::Vector3d(3, 2.5, 2.8));
    const Eigen::Vector3d lo = s.room.min(), hi = s.room.max(), mid = s.room.center();
    const Eigen::Vector3d z = Eigen::Vector3d::UnitZ(), y = Eigen::Vector3d::UnitY();
    uint64_t seed = 100;
    auto texture = [&](double w, double h, double texel, synth::TextureStyle style,
                       std::string_view caption = {}) {
      StatusOr<cv::Mat> t =
          synth::GenerateTexture(static_cast<int>(std::lround(w / texel)),
                                 static_cast<int>(std::lround(h / texel)), style, seed++, caption);
      if (!t.ok()) std::abort();
      return s.AddTexture(*t);
    };
    const auto wall = synth::TextureStyle::kWall;
    const Eigen::Vector3d size = s.room.sizes();
    auto add = [&](const Eigen::Vector3d& c, const Eigen::Vector3d& n, const Eigen::Vector3d& up,
                   double w, double h, synth::TextureStyle style) {
      s.surfaces.push_back(synth::MakeSurface(c, n, up, w, h, texture(w, h, 0.005, style)));
    };
    add({lo.x(), mid.y(), mid.z()}, Eigen::Vector3d::UnitX(), z, size.y(), size.z(), wall);
    add({hi.x(), mid.y(), mid.z()}, -Eigen::Vector3d::UnitX(), z, size.y(), size.z(), wall);
    add({mid.x(), lo.y(), mid.z()}, y, z, size.x(), size.z(), wall);
    add({mid.x(), hi.y(), mid.z()}, -y, z, size.x(), size.z(), wall);
    add({mid.x(), mid.y(), lo.z()}, z, y, size.x(), size.y(), synth::TextureStyle::kFloor);
    add({mid.x(), mid.y(), hi.z()}, -z, y, size.x(), size.y(), synth::TextureStyle::kCeiling);
    const int poster = texture(0.6, 0.8, 0.001, synth::TextureStyle::kObject, "ALIAS");
    a->poster_a = synth::MakeSurface({-1.0, lo.y() + 0.003, 1.45}, y, z, 0.6, 0.8, poster);
    a->poster_b = synth::MakeSurface({1.0, hi.y() - 0.003, 1.45}, -y, z, 0.6, 0.8, poster);
    s.surfaces.push_back(a->poster_a);
    s.surfaces.push_back(a->poster_b);
    if (!synth::ValidateScene(s).ok()) std::abort();
    return a;
  }();
  return *alias;
}

const synth::Renderer& AliasRenderer() {
  static const synth::Renderer* const r = [] {
    StatusOr<synth::Renderer> x =
        synth::Renderer::Create(Alias().scene, synth::DefaultSyntheticCamera());
    if (!x.ok()) std::abort();
    return new synth::Renderer(std::move(x).value());
  }();
  return *r;
}

// A camera 1.3 m up, `distance` in front of the poster and `lateral` to the viewer's right of
// its centre, facing the wall turned by `yaw_deg` (positive: to the left).
Eigen::Isometry3d PosterView(const synth::Surface& poster, double lateral, double distance,
                             double yaw_deg) {
  const Eigen::Vector3d n = poster.Normal();
  Eigen::Vector3d p = poster.Centre() + distance * n + lateral * poster.u_axis;
  p.z() = 1.3;
  const double pitch = std::atan2(poster.Centre().z() - 1.3, distance);
  return synth::LookingPose(p, std::atan2(-n.y(), -n.x()) + yaw_deg * kDeg, pitch);
}

void ExpectNear(const Eigen::Isometry3d& estimated, const Eigen::Isometry3d& truth, double max_m,
                double max_deg) {
  const Eigen::Isometry3d error = truth.inverse() * estimated;
  EXPECT_LT(error.translation().norm(), max_m) << error.translation().transpose();
  EXPECT_LT(AngleDeg(error), max_deg);
}

// --- Options and decision rules ---

TEST(LoopVerifierOptionsTest, DefaultsAreValidAndBadValuesAreRejected) {
  EXPECT_TRUE(LoopVerifierOptions{}.Validate().ok());
  const auto bad = [](auto mutate) {
    LoopVerifierOptions o;
    mutate(o);
    return o.Validate().code() == StatusCode::kInvalidArgument;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(bad([](LoopVerifierOptions& o) { o.min_inliers = o.motion.min_inliers - 1; }));
  EXPECT_TRUE(bad([](LoopVerifierOptions& o) { o.max_rms_px = 0; }));
  EXPECT_TRUE(bad([&](LoopVerifierOptions& o) { o.max_rms_px = nan; }));
  EXPECT_TRUE(bad([](LoopVerifierOptions& o) { o.min_inlier_ratio = -0.1; }));
  EXPECT_TRUE(bad([](LoopVerifierOptions& o) { o.min_inlier_ratio = 1.1; }));
  EXPECT_TRUE(bad([](LoopVerifierOptions& o) { o.max_xi = 0; }));
  EXPECT_TRUE(bad([&](LoopVerifierOptions& o) { o.max_xi = inf; }));
  EXPECT_TRUE(bad([](LoopVerifierOptions& o) { o.matcher.ratio = 0; }));
  EXPECT_TRUE(bad([](LoopVerifierOptions& o) { o.motion.ransac_iterations = 0; }));
  // Bad options are an error of the call, before anything is matched.
  LoopVerifierOptions o;
  o.max_xi = -1;
  StatusOr<LoopVerification> v =
      VerifyLoopCandidate({}, {}, {}, synth::DefaultSyntheticCamera(), o);
  EXPECT_EQ(v.status().code(), StatusCode::kInvalidArgument);
}

TEST(LoopVerifierDecisionTest, Names) {
  EXPECT_EQ(LoopDecisionName(LoopDecision::kAccepted), "accepted");
  EXPECT_EQ(LoopDecisionName(LoopDecision::kTooFewMatches), "too few matches");
  EXPECT_EQ(LoopDecisionName(LoopDecision::kGeometryFailed), "geometry failed");
  EXPECT_EQ(LoopDecisionName(LoopDecision::kXiTooHigh), "xi too high");
  EXPECT_EQ(LoopDecisionName(LoopDecision::kNoNeighbours), "no neighbours");
}

TEST(LoopVerifierDecisionTest, GeometryThresholdsAreInclusive) {
  const LoopVerifierOptions o;  // min_inliers 40, max_rms_px 2, min_inlier_ratio 0.3
  EXPECT_EQ(DecideGeometry(39, 39, 0.5, o), LoopDecision::kTooFewMatches);
  EXPECT_EQ(DecideGeometry(40, 40, 2.0, o), LoopDecision::kAccepted);
  EXPECT_EQ(DecideGeometry(40, 39, 0.5, o), LoopDecision::kGeometryFailed);
  EXPECT_EQ(DecideGeometry(40, 40, 2.0001, o), LoopDecision::kGeometryFailed);
  EXPECT_EQ(DecideGeometry(40, 40, std::numeric_limits<double>::quiet_NaN(), o),
            LoopDecision::kGeometryFailed);
  EXPECT_EQ(DecideGeometry(200, 60, 0.5, o), LoopDecision::kAccepted);  // ratio exactly 0.3
  EXPECT_EQ(DecideGeometry(201, 60, 0.5, o), LoopDecision::kGeometryFailed);
  // The solve needs motion.min_matches correspondences even when min_inliers is lower.
  LoopVerifierOptions m;
  m.motion.min_matches = 50;
  EXPECT_EQ(DecideGeometry(49, 45, 0.5, m), LoopDecision::kTooFewMatches);
  EXPECT_EQ(DecideGeometry(50, 45, 0.5, m), LoopDecision::kAccepted);
}

TEST(LoopVerifierDecisionTest, XiAtTheThresholdIsAccepted) {
  LoopVerifierOptions o;  // max_xi 1.25
  EXPECT_EQ(DecideXi(125, 100, 2, o), LoopDecision::kAccepted);
  EXPECT_EQ(DecideXi(5, 4, 1, o), LoopDecision::kAccepted);
  EXPECT_EQ(DecideXi(126, 100, 2, o), LoopDecision::kXiTooHigh);
  EXPECT_EQ(DecideXi(100, 125, 2, o), LoopDecision::kAccepted);  // neighbours match better
  EXPECT_EQ(DecideXi(100, 0, 2, o), LoopDecision::kXiTooHigh);   // no neighbour supports it
  EXPECT_EQ(CheckXi(100, {0}, o.max_xi).xi, std::numeric_limits<double>::infinity());
  EXPECT_DOUBLE_EQ(CheckXi(125, {100}, o.max_xi).xi, 1.25);
  // A decimal threshold: 11 / 10 rounds to the same double as 1.1.
  o.max_xi = 1.1;
  EXPECT_EQ(DecideXi(11, 10, 1, o), LoopDecision::kAccepted);
  EXPECT_EQ(DecideXi(111, 100, 1, o), LoopDecision::kXiTooHigh);
  // Without neighbours xi is undefined.
  EXPECT_EQ(DecideXi(100, 0, 0, o), LoopDecision::kNoNeighbours);
  o.allow_without_neighbours = true;
  EXPECT_EQ(DecideXi(100, 0, 0, o), LoopDecision::kAccepted);
}

// --- Inputs ---

// n keypoints with depth and `cols`-wide descriptors of `type`.
FrameFeatures HandMade(int n, int type, int cols) {
  FrameFeatures f;
  for (int i = 0; i < n; ++i) {
    f.keypoints.emplace_back(static_cast<float>(10 + i), 20.0f, 31.0f);
    f.points_camera.emplace_back(0.01 * i, 0.0, 2.0);
    f.has_depth.push_back(true);
  }
  f.descriptors = cv::Mat(n, cols, type, cv::Scalar(7));
  return f;
}

TEST(LoopVerifierTest, RejectsInconsistentInputs) {
  const CameraCalibration camera = synth::DefaultSyntheticCamera();
  const FrameFeatures orb = HandMade(5, CV_8UC1, 32);
  const FrameFeatures sift = HandMade(5, CV_32FC1, 128);
  const auto code = [&](const FrameFeatures& q, const FrameFeatures& c,
                        const std::vector<const FrameFeatures*>& n) {
    return VerifyLoopCandidate(q, c, n, camera, {}).status().code();
  };
  EXPECT_EQ(code(orb, sift, {&orb}), StatusCode::kInvalidArgument);
  EXPECT_EQ(code(orb, orb, {&sift}), StatusCode::kInvalidArgument);  // even though N_c fails
  EXPECT_EQ(code(orb, orb, {nullptr}), StatusCode::kInvalidArgument);
  FrameFeatures short_points = orb;
  short_points.points_camera.pop_back();
  EXPECT_EQ(code(orb, short_points, {&orb}), StatusCode::kInvalidArgument);
  FrameFeatures no_depth_flags = orb;
  no_depth_flags.has_depth.clear();
  EXPECT_EQ(code(no_depth_flags, orb, {&orb}), StatusCode::kInvalidArgument);
  CameraCalibration bad_camera = camera;
  bad_camera.fx = 0;
  EXPECT_EQ(VerifyLoopCandidate(orb, orb, {&orb}, bad_camera, {}).status().code(),
            StatusCode::kInvalidArgument);
  // Too little to match is a rejection, not an error.
  StatusOr<LoopVerification> v = VerifyLoopCandidate({}, orb, {&orb}, camera, {});
  ASSERT_TRUE(v.ok()) << v.status().ToString();
  EXPECT_EQ(v->decision, LoopDecision::kTooFewMatches);
  EXPECT_EQ(v->num_matches, 0);
}

// --- The default room ---

// A place in the default room (looking at the +x wall with the table and laptop), a query
// 5.6 cm and 2 degrees off it, and neighbours one keyframe step (0.1 m sideways, 5 degrees of
// turn: about KeyframePolicy's default motion norm) either side.
struct RoomRevisit {
  Eigen::Isometry3d T_world_candidate = RoomPose(0.5, 0.0, 0);
  Eigen::Isometry3d T_world_query = RoomPose(0.55, -0.025, 2);
  FrameFeatures query, candidate;
  std::vector<FrameFeatures> neighbours;
};

const RoomRevisit& Revisit() {
  static const RoomRevisit* const r = [] {
    auto* x = new RoomRevisit;
    const synth::Renderer renderer = MakeRenderer(synth::DefaultSyntheticCamera());
    x->query = Features(renderer, x->T_world_query);
    x->candidate = Features(renderer, x->T_world_candidate);
    for (int s : {-1, 1})
      x->neighbours.push_back(Features(renderer, RoomPose(0.5, 0.1 * s, 5 * s)));
    return x;
  }();
  return *r;
}

TEST(LoopVerifierTest, AcceptsATrueRevisitWithThePose) {
  const RoomRevisit& r = Revisit();
  const LoopVerification v = Verify(r.query, r.candidate, r.neighbours);
  EXPECT_EQ(v.decision, LoopDecision::kAccepted) << LoopDecisionName(v.decision);
  EXPECT_GE(v.num_matches, v.candidate_inliers);
  EXPECT_GT(v.candidate_inliers, 300);
  EXPECT_LT(v.rms_px, 1.5);
  ASSERT_EQ(v.inliers_per_neighbour.size(), 2u);
  EXPECT_EQ(v.neighbour_inliers,
            *std::max_element(v.inliers_per_neighbour.begin(), v.inliers_per_neighbour.end()));
  EXPECT_GT(v.xi, 0.8);
  EXPECT_LE(v.xi, 1.25);
  EXPECT_DOUBLE_EQ(v.xi, static_cast<double>(v.candidate_inliers) / v.neighbour_inliers);
  ExpectNear(v.T_candidate_query, r.T_world_candidate.inverse() * r.T_world_query, 0.005, 0.5);
  EXPECT_TRUE(v.information.isApprox(v.information.transpose(), 1e-9));
  EXPECT_GT(v.information.ldlt().vectorD().minCoeff(), 0.0);
}

TEST(LoopVerifierTest, RejectsACandidateLookingTheOtherWay) {
  const RoomRevisit& r = Revisit();
  const synth::Renderer renderer = MakeRenderer(synth::DefaultSyntheticCamera());
  const FrameFeatures away = Features(renderer, RoomPose(0.5, 0.0, 180));
  const LoopVerification v = Verify(r.query, away, r.neighbours);
  EXPECT_FALSE(v.accepted());
  // No overlap: a few chance matches (12-22 seen), far below what a solve needs.
  EXPECT_EQ(v.decision, LoopDecision::kTooFewMatches) << LoopDecisionName(v.decision);
  EXPECT_LT(v.candidate_inliers, 40);
  EXPECT_TRUE(v.inliers_per_neighbour.empty());  // not solved: geometry decided
  EXPECT_EQ(v.xi, 0.0);
}

TEST(LoopVerifierTest, RejectsMatchesWithoutConsistentGeometry) {
  const RoomRevisit& r = Revisit();
  // The right descriptors with the wrong 3D points (a broken depth association): plenty of
  // matches, no pose explains them.
  FrameFeatures shuffled = r.candidate;
  std::mt19937 rng(5);
  std::shuffle(shuffled.points_camera.begin(), shuffled.points_camera.end(), rng);
  LoopVerification v = Verify(r.query, shuffled, r.neighbours);
  EXPECT_EQ(v.decision, LoopDecision::kGeometryFailed) << LoopDecisionName(v.decision);
  EXPECT_GT(v.num_matches, 300);
  EXPECT_LT(v.candidate_inliers, 40);
  // A good solve fails a reprojection limit below its RMS (about 0.8 px).
  LoopVerifierOptions strict;
  strict.max_rms_px = 0.3;
  v = Verify(r.query, r.candidate, r.neighbours, strict);
  EXPECT_EQ(v.decision, LoopDecision::kGeometryFailed) << LoopDecisionName(v.decision);
  EXPECT_GT(v.candidate_inliers, 300);
}

TEST(LoopVerifierTest, RejectsACandidateItsNeighboursDoNotSupport) {
  const RoomRevisit& r = Revisit();
  const synth::Renderer renderer = MakeRenderer(synth::DefaultSyntheticCamera());
  // The same candidate, but its neighbours are keyframes of a fast turn: they look 40 degrees
  // to either side and share a third of the view with the query (xi 3.8 seen; at 60 degrees
  // they share nothing and xi is infinite).
  std::vector<FrameFeatures> elsewhere;
  for (int s : {-1, 1}) elsewhere.push_back(Features(renderer, RoomPose(0.5, 0.0, 40 * s)));
  const LoopVerification lonely = Verify(r.query, r.candidate, elsewhere);
  const LoopVerification supported = Verify(r.query, r.candidate, r.neighbours);
  EXPECT_EQ(lonely.decision, LoopDecision::kXiTooHigh) << LoopDecisionName(lonely.decision);
  EXPECT_GT(lonely.xi, 2.0);
  EXPECT_GT(lonely.neighbour_inliers, 0);
  // The candidate's own evidence is the same in both.
  EXPECT_EQ(lonely.candidate_inliers, supported.candidate_inliers);
  EXPECT_TRUE(lonely.T_candidate_query.isApprox(supported.T_candidate_query));
  // A threshold at exactly its xi lets the lonely candidate through.
  LoopVerifierOptions loose;
  loose.max_xi = lonely.xi;
  EXPECT_TRUE(Verify(r.query, r.candidate, elsewhere, loose).accepted());
}

TEST(LoopVerifierTest, NeedsNeighboursUnlessAllowedWithout) {
  const RoomRevisit& r = Revisit();
  LoopVerification v = Verify(r.query, r.candidate, {});
  EXPECT_EQ(v.decision, LoopDecision::kNoNeighbours) << LoopDecisionName(v.decision);
  EXPECT_GT(v.candidate_inliers, 300);  // geometry was checked and reported
  EXPECT_EQ(v.xi, 0.0);
  LoopVerifierOptions o;
  o.allow_without_neighbours = true;
  v = Verify(r.query, r.candidate, {}, o);
  EXPECT_EQ(v.decision, LoopDecision::kAccepted) << LoopDecisionName(v.decision);
  ExpectNear(v.T_candidate_query, r.T_world_candidate.inverse() * r.T_world_query, 0.005, 0.5);
}

// --- A perceptual alias ---

// The query faces poster A from 1.5 m. The true candidate faces poster A too; the alias faces
// the identical poster B on the opposite wall from the same relative pose. The alias passes
// geometry (a planar poster explains itself from any wall) with a third of the true
// candidate's inliers. When its neighbours face poster B as well, xi cannot tell it from the
// true revisit: xi compares the candidate with its own neighbourhood, and that neighbourhood
// shares the alias. It is caught only when its neighbours do not see the poster.
TEST(LoopVerifierTest, PerceptualAliasIsCaughtOnlyWhenItsNeighboursMissTheAlias) {
  const AliasScene& a = Alias();
  const synth::Renderer& renderer = AliasRenderer();
  const FrameFeatures query = Features(renderer, PosterView(a.poster_a, 0.05, 1.5, 3));
  const auto around = [&](const synth::Surface& poster, double step_m, double step_deg) {
    std::vector<FrameFeatures> n;
    for (int s : {-1, 1}) {
      n.push_back(Features(renderer, PosterView(poster, s * step_m, 1.5, s * step_deg)));
    }
    return n;
  };
  const FrameFeatures true_candidate = Features(renderer, PosterView(a.poster_a, 0, 1.5, 0));
  const FrameFeatures alias = Features(renderer, PosterView(a.poster_b, 0, 1.5, 0));

  const LoopVerification truth = Verify(query, true_candidate, around(a.poster_a, 0.1, 5));
  EXPECT_EQ(truth.decision, LoopDecision::kAccepted) << LoopDecisionName(truth.decision);
  EXPECT_LE(truth.xi, 1.25);

  const LoopVerification shared = Verify(query, alias, around(a.poster_b, 0.1, 5));
  EXPECT_GE(shared.candidate_inliers, 40);
  EXPECT_LT(shared.candidate_inliers, truth.candidate_inliers / 2);
  EXPECT_NEAR(shared.xi, truth.xi, 0.25);
  EXPECT_EQ(shared.decision, LoopDecision::kAccepted)
      << "xi now rejects an alias its neighbours share; update this test and the header";

  const LoopVerification lonely = Verify(query, alias, around(a.poster_b, 0.0, 45));
  EXPECT_EQ(lonely.decision, LoopDecision::kXiTooHigh) << LoopDecisionName(lonely.decision);
  EXPECT_EQ(lonely.candidate_inliers, shared.candidate_inliers);
}

}  // namespace
}  // namespace semmap
