#include "tests/testing/synth/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/testing/synth/object_template.h"
#include "tests/testing/synth/trajectory.h"
#include "tests/unit/synth/synth_test_util.h"

namespace semmap::synth {
namespace {

using Eigen::Vector3d;
using test::Camera640;
using test::DefaultScene;

Renderer MakeRenderer(const CameraCalibration& camera = Camera640()) {
  StatusOr<Renderer> r = Renderer::Create(DefaultScene(), camera);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return std::move(r).value();
}

double DepthAt(const RenderedFrame& f, int u, int v) {
  return f.depth.at<uint16_t>(v, u) / kDepthScale;
}

const NamedObject& Object(const std::string& label) {
  for (const NamedObject& o : DefaultScene().objects) {
    if (o.label == label) return o;
  }
  std::abort();
}

// A few poses from every trajectory kind.
std::vector<Eigen::Isometry3d> SamplePoses() {
  std::vector<Eigen::Isometry3d> poses;
  for (TrajectoryKind kind :
       {TrajectoryKind::kCircle, TrajectoryKind::kFigureEight, TrajectoryKind::kCorridorLoop,
        TrajectoryKind::kPureRotation, TrajectoryKind::kFastMotion}) {
    TrajectoryOptions options;
    options.frames = 12;
    StatusOr<std::vector<StampedPose>> t = MakeTrajectory(kind, DefaultScene().room, options);
    EXPECT_TRUE(t.ok());
    for (size_t i = 0; i + 1 < t->size(); i += 3) poses.push_back((*t)[i].T_world_camera);
  }
  return poses;
}

TEST(RendererTest, OutputsTheDocumentedImages) {
  const RenderedFrame f = MakeRenderer().Render(LookingPose(Vector3d(0, 0, 1.3), 0.0, 0.0));
  EXPECT_EQ(f.bgr.type(), CV_8UC3);
  EXPECT_EQ(f.depth.type(), CV_16UC1);
  EXPECT_EQ(f.bgr.size(), cv::Size(640, 480));
  EXPECT_EQ(f.depth.size(), cv::Size(640, 480));
}

TEST(RendererTest, WallStraightAheadIsAtItsDistance) {
  // From the room's centre looking at the +x wall (3 m away); the table stands at y < 0.05 and
  // z < 0.75, below and to the right of the image centre.
  const RenderedFrame f = MakeRenderer().Render(LookingPose(Vector3d(0, 1.0, 1.5), 0.0, 0.0));
  // Pixel (319.5, 239.5) is the optical axis: the four centre pixels are all at x = 3.
  for (int v : {239, 240}) {
    for (int u : {319, 320}) EXPECT_NEAR(DepthAt(f, u, v), 3.0, 0.0003);
  }
  // Any wall pixel: depth along the axis stays 3 m (a plane facing the camera).
  EXPECT_NEAR(DepthAt(f, 100, 100), 3.0, 0.0003);
}

TEST(RendererTest, UnprojectedPixelsLieOnSceneSurfaces) {
  const Renderer renderer = MakeRenderer();
  const std::vector<Surface> surfaces = DefaultScene().AllSurfaces();
  const CameraCalibration c = Camera640();
  for (const Eigen::Isometry3d& T : SamplePoses()) {
    const RenderedFrame f = renderer.Render(T);
    int far_off = 0, checked = 0;
    for (int v = 3; v < c.height; v += 12) {
      for (int u = 5; u < c.width; u += 12) {
        const double z = DepthAt(f, u, v);
        ASSERT_GT(z, 0.0) << "hole at " << u << "," << v;
        const Vector3d p = test::Unproject(c, T, u, v, z);
        double best = 1e9;
        for (const Surface& s : surfaces) best = std::min(best, test::DistanceToSurface(s, p));
        far_off += best > 0.01;
        ++checked;
      }
    }
    EXPECT_EQ(far_off, 0) << "of " << checked;
  }
}

TEST(RendererTest, DepthMatchesAnIndependentRayCast) {
  // Nearest-surface depth per pixel against a brute-force reference; only pixels right on a
  // silhouette edge may pick the other side.
  const Renderer renderer = MakeRenderer();
  const std::vector<Surface> surfaces = DefaultScene().AllSurfaces();
  const CameraCalibration c = Camera640();
  for (const Eigen::Isometry3d& T : SamplePoses()) {
    const RenderedFrame f = renderer.Render(T);
    int mismatches = 0, checked = 0;
    for (int v = 0; v < c.height; v += 7) {
      for (int u = 0; u < c.width; u += 7) {
        const double ref = test::ReferenceDepth(surfaces, c, T, u, v);
        ASSERT_TRUE(std::isfinite(ref));
        mismatches += std::abs(DepthAt(f, u, v) - ref) > 0.001;
        ++checked;
      }
    }
    EXPECT_LE(mismatches, checked / 500) << "of " << checked;
  }
}

TEST(RendererTest, ObjectCentrePointsProjectWhereTheDepthSaysTheyAre) {
  // The centre of each object's front face, seen from 1.5 m away and off-axis: the pixel it
  // projects to unprojects (with the rendered depth and the pose) to the same point.
  const Renderer renderer = MakeRenderer();
  const CameraCalibration c = Camera640();
  for (const NamedObject& o : DefaultScene().objects) {
    SCOPED_TRACE(o.label);
    const Vector3d target = o.front.Centre();
    const Vector3d eye = target + 1.5 * o.front.Normal() + Vector3d(0.2, -0.15, 0.3);
    const Vector3d dir = (target - eye).normalized();
    const Eigen::Isometry3d T =
        LookingPose(eye, std::atan2(dir.y(), dir.x()) + 0.1, std::asin(dir.z()) - 0.05);
    const RenderedFrame f = renderer.Render(T);
    const std::optional<Eigen::Vector2d> px = test::Project(c, T, target);
    ASSERT_TRUE(px.has_value());
    const int u = static_cast<int>(std::lround(px->x())),
              v = static_cast<int>(std::lround(px->y()));
    ASSERT_TRUE(u >= 0 && u < c.width && v >= 0 && v < c.height);
    const Vector3d seen = test::Unproject(c, T, u, v, DepthAt(f, u, v));
    EXPECT_LT((seen - target).norm(), 0.01) << seen.transpose() << " vs " << target.transpose();
    // And the unrounded pixel position agrees with the face plane to well under a millimetre.
    EXPECT_LT(std::abs((seen - target).dot(o.front.Normal())), 0.001);
  }
}

TEST(RendererTest, TexturesAppearUprightAndUnmirrored) {
  // The poster seen straight on at one texel per pixel reproduces its texture image.
  const NamedObject& poster = Object("mug_poster");
  TemplateOptions options;
  options.margin = 0.0;
  StatusOr<cv::Mat> view = RenderObjectTemplate(MakeRenderer(), poster, options);
  ASSERT_TRUE(view.ok()) << view.status().ToString();
  const cv::Mat& texture = DefaultScene().textures[static_cast<size_t>(poster.front.texture)];
  ASSERT_EQ(view->size(), texture.size());
  cv::Mat a, b, flipped;
  cv::cvtColor(*view, a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(texture, b, cv::COLOR_BGR2GRAY);
  a.convertTo(a, CV_32F);
  b.convertTo(b, CV_32F);
  cv::flip(b, flipped, 1);
  auto correlation = [](const cv::Mat& x, const cv::Mat& y) {
    cv::Mat r;
    cv::matchTemplate(x, y, r, cv::TM_CCOEFF_NORMED);
    return r.at<float>(0, 0);
  };
  EXPECT_GT(correlation(a, b), 0.9);
  EXPECT_LT(correlation(a, flipped), 0.3);
}

TEST(RendererTest, IsDeterministicAndSharesTexturesAcrossCameras) {
  const Renderer renderer = MakeRenderer();
  const Eigen::Isometry3d T = LookingPose(Vector3d(0.3, -0.2, 1.2), 2.0, -0.3, 0.1);
  const RenderedFrame a = renderer.Render(T);
  RenderedFrame b;
  renderer.Render(T, &b);
  EXPECT_EQ(cv::norm(a.bgr, b.bgr, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a.depth, b.depth, cv::NORM_INF), 0);

  CameraCalibration small = Camera640();
  small.width = 320;
  small.height = 240;
  small.fx = small.fy = 262.5;
  small.cx = 159.5;
  small.cy = 119.5;
  StatusOr<Renderer> half = renderer.WithCamera(small);
  ASSERT_TRUE(half.ok());
  const RenderedFrame s = half->Render(T);
  EXPECT_EQ(s.bgr.size(), cv::Size(320, 240));
  const std::vector<Surface> surfaces = DefaultScene().AllSurfaces();
  for (int v = 20; v < 240; v += 50) {
    for (int u = 20; u < 320; u += 50) {
      EXPECT_NEAR(DepthAt(s, u, v), test::ReferenceDepth(surfaces, small, T, u, v), 0.001)
          << u << "," << v;
    }
  }
}

TEST(RendererTest, RejectsUnsupportedCameras) {
  CameraCalibration c = Camera640();
  c.distortion[0] = 0.1;
  EXPECT_EQ(Renderer::Create(DefaultScene(), c).status().code(), StatusCode::kInvalidArgument);
  c = Camera640();
  c.fx = 0;
  EXPECT_FALSE(Renderer::Create(DefaultScene(), c).ok());
  EXPECT_FALSE(MakeRenderer().WithCamera(c).ok());
}

TEST(RendererTest, EmptyViewsAreBlackWithoutDepth) {
  // Outside the room looking away from it: nothing in view.
  const RenderedFrame f = MakeRenderer().Render(LookingPose(Vector3d(-8, 0, 1.4), 3.14159, 0.0));
  EXPECT_EQ(cv::countNonZero(f.depth), 0);
  EXPECT_EQ(cv::norm(f.bgr, cv::NORM_INF), 0);
  // A broken (NaN) pose renders nothing rather than garbage.
  Eigen::Isometry3d broken = Eigen::Isometry3d::Identity();
  broken.translation().x() = std::nan("");
  EXPECT_EQ(cv::countNonZero(MakeRenderer().Render(broken).depth), 0);
}

TEST(RendererTest, NearbyAndDistantSurfacesBothRenderWithoutHoles) {
  // Very close to a wall (20 cm) and looking along the long diagonal at a grazing floor.
  const Renderer renderer = MakeRenderer();
  for (const Eigen::Isometry3d& T : {LookingPose(Vector3d(0, 2.3, 1.5), 1.5707963, 0.0),
                                     LookingPose(Vector3d(-2.0, -1.3, 0.3), 0.7, -0.05)}) {
    const RenderedFrame f = renderer.Render(T);
    EXPECT_EQ(cv::countNonZero(f.depth), 640 * 480);
  }
}

}  // namespace
}  // namespace semmap::synth
