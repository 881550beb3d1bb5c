// RenderMapPng: pictures decoded back with cv::imdecode and checked at the pixels that
// MapViewProjection gives for known world points (a green floor at y = 0 under cameras at
// y = -1 facing +z, camera convention), plus the view basis, options and input checks.
#include "core/mapping/map_render.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <utility>
#include <vector>

namespace semmap {
namespace {

constexpr double kPi = 3.14159265358979323846;
const std::array<uint8_t, 3> kFloorRgb = {70, 160, 70};
const std::array<uint8_t, 3> kBoxRgb = {40, 70, 230};

Eigen::Isometry3d CameraAt(const Eigen::Vector3d& t, const Eigen::Matrix3d& R) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

Eigen::Isometry3d LevelCamera(double x, double z) {
  return CameraAt({x, -1, z}, Eigen::Matrix3d::Identity());
}

void AddPatch(std::vector<RenderPoint>& cloud, double x0, double x1, double z0, double z1, double y,
              double spacing, const std::array<uint8_t, 3>& rgb) {
  const int nx = static_cast<int>(std::lround((x1 - x0) / spacing));
  const int nz = static_cast<int>(std::lround((z1 - z0) / spacing));
  for (int i = 0; i <= nx; ++i) {
    for (int k = 0; k <= nz; ++k) {
      cloud.push_back({static_cast<float>(x0 + i * spacing), static_cast<float>(y),
                       static_cast<float>(z0 + k * spacing), rgb[0], rgb[1], rgb[2]});
    }
  }
}

// Floor x in [-2, 2], z in [-0.5, 4.5] (2 cm voxels); a box of points x in [-1.2, -0.8],
// z in [2.8, 3.2], y in [-0.4, 0] (top face and sides); cameras along x = 0.8 at y = -1.
MapRenderInput Scene() {
  MapRenderInput in;
  in.title = "test room";
  AddPatch(in.cloud, -2, 2, -0.5, 4.5, 0, 0.02, kFloorRgb);
  AddPatch(in.cloud, -1.2, -0.8, 2.8, 3.2, -0.4, 0.02, kBoxRgb);
  for (double y = -0.38; y < 0; y += 0.02) {
    for (double s = -1.2; s <= -0.8 + 1e-9; s += 0.02) {
      for (const auto& [x, z] : std::vector<std::pair<double, double>>{
               {s, 2.8}, {s, 3.2}, {-1.2, s + 4.0}, {-0.8, s + 4.0}}) {
        in.cloud.push_back({static_cast<float>(x), static_cast<float>(y), static_cast<float>(z),
                            kBoxRgb[0], kBoxRgb[1], kBoxRgb[2]});
      }
    }
  }
  std::vector<Eigen::Isometry3d> trajectory;
  for (double z = 0; z <= 3.5 + 1e-9; z += 0.05) trajectory.push_back(LevelCamera(0.8, z));
  in.trajectories.push_back(trajectory);
  for (double z = 0; z <= 3.5 + 1e-9; z += 0.5) in.keyframes.push_back(LevelCamera(0.8, z));
  in.loop_edges.push_back({{0.8, -1, 0}, {0.8, -1, 3.5}});
  RenderObject box;
  box.label = "box";
  box.centre = {-1.0, -0.2, 3.0};
  box.extent = {0.4, 0.4, 0.4};
  box.rgb = {255, 140, 0};
  in.objects.push_back(box);
  return in;
}

cv::Mat Decode(const std::string& png) {
  const std::vector<uchar> bytes(png.begin(), png.end());
  return cv::imdecode(bytes, cv::IMREAD_COLOR);
}

cv::Mat RenderOrDie(const MapRenderInput& in, const MapRenderOptions& options) {
  StatusOr<std::string> png = RenderMapPng(in, options);
  EXPECT_TRUE(png.ok()) << png.status().ToString();
  if (!png.ok()) return {};
  cv::Mat image = Decode(*png);
  EXPECT_FALSE(image.empty());
  return image;
}

MapViewProjection ProjectionOrDie(const MapRenderInput& in, const MapRenderOptions& options) {
  StatusOr<MapViewProjection> p = ComputeMapViewProjection(in, options);
  EXPECT_TRUE(p.ok()) << p.status().ToString();
  return p.ok() ? *p : MapViewProjection{};
}

cv::Point PixelOf(const MapViewProjection& p, const Eigen::Vector3d& world) {
  const Eigen::Vector2d px = p.ToPixel(world);
  return {static_cast<int>(std::lround(px.x())), static_cast<int>(std::lround(px.y()))};
}

// RGB at a pixel.
std::array<int, 3> RgbAt(const cv::Mat& image, cv::Point px) {
  const cv::Vec3b& bgr = image.at<cv::Vec3b>(px);
  return {bgr[2], bgr[1], bgr[0]};
}

bool Near(const std::array<int, 3>& rgb, const std::array<uint8_t, 3>& want, int tolerance) {
  for (int c = 0; c < 3; ++c) {
    if (std::abs(rgb[c] - want[c]) > tolerance) return false;
  }
  return true;
}

bool IsRed(const cv::Vec3b& bgr) { return bgr[2] > 170 && bgr[1] < 100 && bgr[0] < 100; }

TEST(MapRenderTest, SizeFollowsLongSideAndAspect) {
  MapRenderOptions options;
  options.long_side_px = 900;
  // The scene is taller (z: 5 m) than wide (x: 4 m): portrait.
  const cv::Mat portrait = RenderOrDie(Scene(), options);
  ASSERT_FALSE(portrait.empty());
  EXPECT_EQ(portrait.rows, 900);
  EXPECT_GE(portrait.cols, 450);
  EXPECT_LT(portrait.cols, 900);
  const MapViewProjection p = ProjectionOrDie(Scene(), options);
  EXPECT_EQ(p.image_width, portrait.cols);
  EXPECT_EQ(p.image_height, portrait.rows);

  // Wide and thin (10 m x 1 m): landscape, the short side no less than half the long one.
  MapRenderInput wide;
  AddPatch(wide.cloud, 0, 10, 0, 1, 0, 0.05, kFloorRgb);
  options.long_side_px = 1000;
  const cv::Mat landscape = RenderOrDie(wide, options);
  ASSERT_FALSE(landscape.empty());
  EXPECT_EQ(landscape.cols, 1000);
  EXPECT_EQ(landscape.rows, 500);
  EXPECT_EQ(landscape.type(), CV_8UC3);
}

TEST(MapRenderTest, ViewBasisFromLevelCameras) {
  const MapViewProjection p = ProjectionOrDie(Scene(), MapRenderOptions{});
  EXPECT_TRUE(p.up.isApprox(Eigen::Vector3d(0, -1, 0), 1e-9));
  EXPECT_TRUE(p.forward.isApprox(Eigen::Vector3d(0, 0, 1), 1e-9));
  EXPECT_TRUE(p.right.isApprox(Eigen::Vector3d(1, 0, 0), 1e-9));
  // +x goes right, +z (the first camera's heading) goes up in the picture.
  const Eigen::Vector2d o = p.ToPixel({0, 0, 0});
  EXPECT_GT(p.ToPixel({1, 0, 0}).x(), o.x() + 10);
  EXPECT_LT(p.ToPixel({0, 0, 1}).y(), o.y() - 10);
  EXPECT_NEAR(p.ToPixel({1, 0, 0}).x() - o.x(), p.pixels_per_metre, 1e-9);
  // Cameras at height 1: points above 1.5 m are clipped.
  EXPECT_NEAR(p.clip_height, 1.5, 1e-9);
  EXPECT_NEAR(p.floor_height, 0, 1e-6);
}

TEST(MapRenderTest, HeadingOfFirstCameraPointsUp) {
  // The first camera faces +x (yawed about the world's vertical y axis): +x points up.
  MapRenderInput in;
  const Eigen::Matrix3d yaw =
      Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  in.trajectories.push_back({CameraAt({0, -1, 0}, yaw), CameraAt({2, -1, 0}, yaw)});
  const MapViewProjection p = ProjectionOrDie(in, MapRenderOptions{});
  EXPECT_TRUE(p.forward.isApprox(Eigen::Vector3d(1, 0, 0), 1e-9));
  EXPECT_LT(p.ToPixel({1, 0, 0}).y(), p.ToPixel({0, 0, 0}).y() - 10);
  // Not mirrored: +z ends up on the left (right = forward x up = x cross -y = -z).
  EXPECT_TRUE(p.right.isApprox(Eigen::Vector3d(0, 0, -1), 1e-9));
}

TEST(MapRenderTest, CloudColoursAtExpectedPixels) {
  const MapRenderInput in = Scene();
  MapRenderOptions options;
  options.long_side_px = 1000;
  const cv::Mat image = RenderOrDie(in, options);
  ASSERT_FALSE(image.empty());
  const MapViewProjection p = ProjectionOrDie(in, options);
  for (const Eigen::Vector3d& floor :
       {Eigen::Vector3d(1.5, 0, 1.0), Eigen::Vector3d(-1.5, 0, 0.0), Eigen::Vector3d(0, 0, 4.0)}) {
    EXPECT_TRUE(Near(RgbAt(image, PixelOf(p, floor)), kFloorRgb, 2)) << floor.transpose();
  }
  // The box's top face (0.4 m up) covers the floor under it.
  EXPECT_TRUE(Near(RgbAt(image, PixelOf(p, {-1.0, -0.4, 3.0})), kBoxRgb, 2));
  // Outside the cloud: light background.
  const std::array<int, 3> outside = RgbAt(image, PixelOf(p, {-2.15, 0, -0.6}));
  EXPECT_GT(outside[0], 200);
  EXPECT_EQ(outside[0], outside[1]);
  EXPECT_EQ(outside[1], outside[2]);
}

TEST(MapRenderTest, TwoCentimetreVoxelFloorIsSolid) {
  const MapRenderInput in = Scene();
  for (int long_side : {600, 1600, 4000}) {
    MapRenderOptions options;
    options.long_side_px = long_side;
    const cv::Mat image = RenderOrDie(in, options);
    ASSERT_FALSE(image.empty());
    const MapViewProjection p = ProjectionOrDie(in, options);
    // A floor region away from the box, the trajectory and the legend: no background shows.
    const cv::Point a = PixelOf(p, {1.2, 0, 3.0});
    const cv::Point b = PixelOf(p, {1.9, 0, 0.5});
    int holes = 0, total = 0;
    for (int y = a.y; y <= b.y; ++y) {
      for (int x = a.x; x <= b.x; ++x) {
        ++total;
        if (!Near(RgbAt(image, {x, y}), kFloorRgb, 2)) ++holes;
      }
    }
    EXPECT_GT(total, 100);
    EXPECT_EQ(holes, 0) << "long side " << long_side;
  }
}

TEST(MapRenderTest, HigherPointsCoverLowerOnes) {
  // A blue patch 0.3 m above a green floor; either input order gives the same picture.
  for (bool floor_first : {true, false}) {
    MapRenderInput in;
    std::vector<RenderPoint> floor, top;
    AddPatch(floor, -1, 1, -1, 1, 0, 0.02, kFloorRgb);
    AddPatch(top, -0.25, 0.25, -0.25, 0.25, -0.3, 0.02, kBoxRgb);
    in.cloud = floor_first ? floor : top;
    in.cloud.insert(in.cloud.end(), (floor_first ? top : floor).begin(),
                    (floor_first ? top : floor).end());
    MapRenderOptions options;
    options.long_side_px = 800;
    const cv::Mat image = RenderOrDie(in, options);
    ASSERT_FALSE(image.empty());
    const MapViewProjection p = ProjectionOrDie(in, options);
    EXPECT_TRUE(p.up.isApprox(Eigen::Vector3d(0, -1, 0)));  // no cameras: -y
    EXPECT_TRUE(Near(RgbAt(image, PixelOf(p, {0, -0.3, 0})), kBoxRgb, 2)) << floor_first;
    EXPECT_TRUE(Near(RgbAt(image, PixelOf(p, {0.2, -0.3, -0.2})), kBoxRgb, 2)) << floor_first;
    // The floor is still visible where nothing is above it.
    EXPECT_TRUE(Near(RgbAt(image, PixelOf(p, {0.7, 0, 0.7})), kFloorRgb, 2)) << floor_first;
    EXPECT_TRUE(Near(RgbAt(image, PixelOf(p, {-0.6, 0, 0})), kFloorRgb, 2)) << floor_first;
  }
}

TEST(MapRenderTest, CeilingAboveTheCamerasIsClipped) {
  MapRenderInput in = Scene();
  AddPatch(in.cloud, -2, 2, -0.5, 4.5, -2.6, 0.02, {250, 250, 250});  // 1.6 m above the cameras
  MapRenderOptions options;
  options.long_side_px = 800;
  const cv::Mat image = RenderOrDie(in, options);
  ASSERT_FALSE(image.empty());
  const MapViewProjection p = ProjectionOrDie(in, options);
  EXPECT_TRUE(Near(RgbAt(image, PixelOf(p, {1.5, 0, 1.0})), kFloorRgb, 2));

  options.clip_above_camera_m = std::numeric_limits<double>::infinity();
  const cv::Mat unclipped = RenderOrDie(in, options);
  ASSERT_FALSE(unclipped.empty());
  EXPECT_TRUE(Near(RgbAt(unclipped, PixelOf(p, {1.5, 0, 1.0})), {250, 250, 250}, 2));
}

TEST(MapRenderTest, TrajectoryIsRed) {
  const MapRenderInput in = Scene();
  MapRenderOptions options;
  options.long_side_px = 1000;
  const cv::Mat image = RenderOrDie(in, options);
  ASSERT_FALSE(image.empty());
  const MapViewProjection p = ProjectionOrDie(in, options);
  // Between keyframe markers (every 0.5 m), within a pixel of the path.
  for (double z = 0.25; z < 3.5; z += 0.5) {
    const cv::Point c = PixelOf(p, {0.8, -1, z});
    bool red = false;
    for (int dx = -1; dx <= 1; ++dx) red = red || IsRed(image.at<cv::Vec3b>(c + cv::Point(dx, 0)));
    EXPECT_TRUE(red) << "z " << z;
  }
  // Not red away from it.
  EXPECT_FALSE(IsRed(image.at<cv::Vec3b>(PixelOf(p, {1.4, -1, 1.75}))));
}

TEST(MapRenderTest, ObjectLabelDrawnAboveTheBox) {
  MapRenderInput with_label = Scene();
  MapRenderInput without_label = Scene();
  with_label.objects[0].label = "chair";
  without_label.objects[0].label = "";
  MapRenderOptions options;
  options.long_side_px = 1000;
  const cv::Mat a = RenderOrDie(with_label, options);
  const cv::Mat b = RenderOrDie(without_label, options);
  ASSERT_FALSE(a.empty());
  ASSERT_FALSE(b.empty());
  const MapViewProjection p = ProjectionOrDie(with_label, options);
  const cv::Point box_far_edge = PixelOf(p, {-1.0, -0.4, 3.2});  // the top of the outline
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  cv::Mat gray;
  cv::extractChannel(diff, gray, 0);
  cv::Mat changed = gray > 0;
  for (int c = 1; c < 3; ++c) {
    cv::extractChannel(diff, gray, c);
    changed |= gray > 0;
  }
  const cv::Rect changes = cv::boundingRect(changed);
  ASSERT_GT(cv::countNonZero(changed), 50);
  // The label box sits just above the outline, centred on it.
  EXPECT_LE(changes.y + changes.height, box_far_edge.y + 2);
  EXPECT_GE(changes.y, box_far_edge.y - 60);
  EXPECT_LE(std::abs(changes.x + changes.width / 2 - box_far_edge.x), 3);
  // Dark text on a light panel.
  int dark = 0, light = 0;
  for (int y = changes.y; y < changes.y + changes.height; ++y) {
    for (int x = changes.x; x < changes.x + changes.width; ++x) {
      const cv::Vec3b& v = a.at<cv::Vec3b>(y, x);
      if (v[0] < 90 && v[1] < 90 && v[2] < 90) ++dark;
      if (v[0] > 220 && v[1] > 220 && v[2] > 220) ++light;
    }
  }
  EXPECT_GT(dark, 20);
  EXPECT_GT(light, dark);
}

TEST(MapRenderTest, MetreGridUnderTheMap) {
  // Poses only (no cloud over the grid): a 4 m x 3 m map.
  MapRenderInput in;
  in.trajectories.push_back({LevelCamera(0, 0), LevelCamera(4, 0), LevelCamera(4, 3)});
  MapRenderOptions options;
  options.long_side_px = 1000;
  const cv::Mat image = RenderOrDie(in, options);
  ASSERT_FALSE(image.empty());
  const MapViewProjection p = ProjectionOrDie(in, options);
  ASSERT_DOUBLE_EQ(p.grid_step_m, 1.0);
  const auto column_mean = [&](double x_world) {
    const int x = PixelOf(p, {x_world, 0, 0}).x;
    const int y0 = PixelOf(p, {0, 0, 2.5}).y, y1 = PixelOf(p, {0, 0, 0.5}).y;
    double sum = 0;
    for (int y = y0; y <= y1; ++y) sum += image.at<cv::Vec3b>(y, x)[1];
    return sum / (y1 - y0 + 1);
  };
  // Lines at 1, 2, 3 m; none half-way between them (there only background).
  for (double x : {1.0, 2.0, 3.0}) EXPECT_LT(column_mean(x), column_mean(x + 0.5) - 10) << x;
  EXPECT_GT(column_mean(1.5), 235);
  EXPECT_LT(column_mean(2.0), 230);
}

TEST(MapRenderTest, EmptyMapRendersAPicture) {
  MapRenderInput in;
  in.title = "nothing yet";
  MapRenderOptions options;
  options.long_side_px = 640;
  const cv::Mat image = RenderOrDie(in, options);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(std::max(image.rows, image.cols), 640);
  EXPECT_GE(std::min(image.rows, image.cols), 320);
  // Mostly light, with some text.
  cv::Mat gray;
  cv::extractChannel(image, gray, 1);
  EXPECT_GT(cv::mean(gray)[0], 220);
  EXPECT_GT(cv::countNonZero(gray < 100), 50);

  // Oblique too, and with the smallest size.
  options.view = RenderView::kOblique;
  options.long_side_px = 200;
  EXPECT_FALSE(RenderOrDie(in, options).empty());
}

TEST(MapRenderTest, ObliqueViewTiltsTowardsTheHeading) {
  const MapRenderInput in = Scene();
  MapRenderOptions options;
  options.view = RenderView::kOblique;
  options.long_side_px = 1000;
  const cv::Mat image = RenderOrDie(in, options);
  ASSERT_FALSE(image.empty());
  const MapViewProjection p = ProjectionOrDie(in, options);
  const double t = 35 * kPi / 180;
  EXPECT_TRUE(p.image_up.isApprox(Eigen::Vector3d(0, -std::sin(t), std::cos(t)), 1e-9));
  EXPECT_NEAR(p.toward_viewer.dot(p.image_up), 0, 1e-12);
  EXPECT_NEAR(p.right.dot(p.image_up), 0, 1e-12);
  // Higher points appear higher up in the picture; the box top is visible.
  EXPECT_LT(p.ToPixel({0, -1, 1}).y(), p.ToPixel({0, 0, 1}).y() - 10);
  EXPECT_TRUE(Near(RgbAt(image, PixelOf(p, {-1.0, -0.4, 3.0})), kBoxRgb, 2));
  EXPECT_TRUE(Near(RgbAt(image, PixelOf(p, {1.5, 0, 1.0})), kFloorRgb, 2));
}

TEST(MapRenderTest, StrayPointsDoNotShrinkTheMap) {
  MapRenderInput in = Scene();
  const double ppm = ProjectionOrDie(in, MapRenderOptions{}).pixels_per_metre;
  in.cloud.push_back({500, 0, 500, 255, 255, 255});
  in.cloud.push_back({-300, 0, 20, 255, 255, 255});
  EXPECT_NEAR(ProjectionOrDie(in, MapRenderOptions{}).pixels_per_metre, ppm, 0.02 * ppm);
  EXPECT_TRUE(RenderMapPng(in, MapRenderOptions{}).ok());
}

TEST(MapRenderTest, ExplicitUpDirection) {
  // A z-up world without cameras: forward falls back to world +x, right = x cross z = -y.
  MapRenderInput in;
  AddPatch(in.cloud, 0, 2, 0, 1, 0, 0.05, kFloorRgb);
  MapRenderOptions options;
  options.up = Eigen::Vector3d(0, 0, 2);
  const MapViewProjection p = ProjectionOrDie(in, options);
  EXPECT_TRUE(p.up.isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
  EXPECT_TRUE(p.forward.isApprox(Eigen::Vector3d(1, 0, 0), 1e-12));
  EXPECT_TRUE(p.right.isApprox(Eigen::Vector3d(0, -1, 0), 1e-12));
}

TEST(MapRenderTest, BadOptionsAreInvalidArgument) {
  const MapRenderInput in = Scene();
  const auto code = [&](const MapRenderOptions& o) { return RenderMapPng(in, o).status().code(); };
  MapRenderOptions o;
  EXPECT_EQ(code(o), StatusCode::kOk);
  o.long_side_px = 199;
  EXPECT_EQ(code(o), StatusCode::kInvalidArgument);
  o.long_side_px = 8001;
  EXPECT_EQ(code(o), StatusCode::kInvalidArgument);
  o = MapRenderOptions{};
  o.up = Eigen::Vector3d::Zero();
  EXPECT_EQ(code(o), StatusCode::kInvalidArgument);
  o.up = Eigen::Vector3d(0, std::nan(""), 1);
  EXPECT_EQ(code(o), StatusCode::kInvalidArgument);
  o = MapRenderOptions{};
  o.oblique_tilt_deg = 0;
  EXPECT_EQ(code(o), StatusCode::kInvalidArgument);
  o = MapRenderOptions{};
  o.clip_above_camera_m = std::nan("");
  EXPECT_EQ(code(o), StatusCode::kInvalidArgument);
  EXPECT_EQ(ComputeMapViewProjection(in, o).status().code(), StatusCode::kInvalidArgument);
}

TEST(MapRenderTest, NonFiniteInputIsInvalidArgument) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const auto code = [](const MapRenderInput& in) {
    return RenderMapPng(in, MapRenderOptions{}).status().code();
  };
  MapRenderInput in = Scene();
  in.cloud[7].y = nan;
  EXPECT_EQ(code(in), StatusCode::kInvalidArgument);
  in = Scene();
  in.cloud[3].x = std::numeric_limits<float>::infinity();
  EXPECT_EQ(code(in), StatusCode::kInvalidArgument);
  in = Scene();
  in.trajectories[0][2].translation().x() = nan;
  EXPECT_EQ(code(in), StatusCode::kInvalidArgument);
  in = Scene();
  in.keyframes[1].linear()(0, 0) = nan;
  EXPECT_EQ(code(in), StatusCode::kInvalidArgument);
  in = Scene();
  in.loop_edges[0].second.z() = nan;
  EXPECT_EQ(code(in), StatusCode::kInvalidArgument);
  in = Scene();
  in.objects[0].centre.x() = nan;
  EXPECT_EQ(code(in), StatusCode::kInvalidArgument);
  in = Scene();
  in.cloud[5].z = 2e6f;  // finite, but no map is that big
  EXPECT_EQ(code(in), StatusCode::kInvalidArgument);
  in = Scene();
  in.objects[0].extent.y() = -0.1;
  EXPECT_EQ(code(in), StatusCode::kInvalidArgument);
}

TEST(MapRenderTest, EstimateUpDirectionFromCameras) {
  // Level cameras looking in several directions (yaw about the vertical y axis): -y.
  std::vector<Eigen::Isometry3d> level;
  for (double yaw : {0.0, 0.7, 2.0, -2.5}) {
    level.push_back(CameraAt({yaw, -1, 0},
                             Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix()));
  }
  EXPECT_TRUE(EstimateUpDirection(level).isApprox(Eigen::Vector3d(0, -1, 0), 1e-9));

  // Rolled by 90 degrees about the optical axis (then yawed about the new up): their -y.
  const Eigen::Matrix3d roll =
      Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d want = -(roll.col(1));  // (1, 0, 0)
  std::vector<Eigen::Isometry3d> rolled;
  for (double yaw : {0.0, 0.4, -0.9}) {
    rolled.push_back(CameraAt({0, 0, 0}, Eigen::AngleAxisd(yaw, want).toRotationMatrix() * roll));
  }
  EXPECT_TRUE(want.isApprox(Eigen::Vector3d(1, 0, 0), 1e-12));
  EXPECT_TRUE(EstimateUpDirection(rolled).isApprox(want, 1e-9));

  // All pitched down by 20 degrees, headings spread: the x axes still give -y exactly (the
  // mean -y axis would be 20 degrees off).
  std::vector<Eigen::Isometry3d> looking_down;
  for (double yaw : {0.0, 0.5, 1.0, 1.5}) {
    looking_down.push_back(
        CameraAt({0, -1.4, yaw}, (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(-20 * kPi / 180, Eigen::Vector3d::UnitX()))
                                     .toRotationMatrix()));
  }
  EXPECT_TRUE(EstimateUpDirection(looking_down).isApprox(Eigen::Vector3d(0, -1, 0), 1e-9));

  // Slightly pitched cameras, same heading: the mean -y, about -y, unit length.
  std::vector<Eigen::Isometry3d> pitched;
  for (double pitch : {0.2, -0.2}) {
    pitched.push_back(
        CameraAt({0, 0, 0}, Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()).toRotationMatrix()));
  }
  const Eigen::Vector3d up = EstimateUpDirection(pitched);
  EXPECT_NEAR(up.norm(), 1, 1e-12);
  EXPECT_TRUE(up.isApprox(Eigen::Vector3d(0, -1, 0), 1e-9));

  // No cameras, or cameras that cancel out: the world's -y.
  EXPECT_TRUE(EstimateUpDirection({}).isApprox(Eigen::Vector3d(0, -1, 0)));
  const Eigen::Matrix3d flipped =
      Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(EstimateUpDirection(
                  {CameraAt({0, 0, 0}, Eigen::Matrix3d::Identity()), CameraAt({0, 0, 0}, flipped)})
                  .isApprox(Eigen::Vector3d(0, -1, 0)));
}

TEST(MapRenderTest, Renders300kPointsQuickly) {
  // A 10 m x 7.5 m floor at 2 cm (~188k points) plus a wall and furniture: ~300k.
  MapRenderInput in;
  AddPatch(in.cloud, -5, 5, -1, 6.5, 0, 0.02, kFloorRgb);
  for (double y = -2; y < 0; y += 0.02)
    AddPatch(in.cloud, -5, 5, 6.5, 6.5, y, 0.02, {200, 200, 190});
  for (double y = -0.8; y < 0; y += 0.02) AddPatch(in.cloud, 1, 3, 2, 2.6, y, 0.02, {150, 100, 60});
  AddPatch(in.cloud, -4, -2, 1, 3, -0.75, 0.02, {120, 80, 50});
  std::vector<Eigen::Isometry3d> trajectory;
  for (int i = 0; i < 600; ++i) {
    const double a = 2 * kPi * i / 600;
    trajectory.push_back(
        CameraAt({3 * std::cos(a), -1.3, 2.5 + 2 * std::sin(a)},
                 Eigen::AngleAxisd(-a, Eigen::Vector3d::UnitY()).toRotationMatrix()));
  }
  in.trajectories.push_back(trajectory);
  std::cout << "points: " << in.cloud.size() << "\n";
  ASSERT_GT(in.cloud.size(), 250000u);
  for (RenderView view : {RenderView::kTopDown, RenderView::kOblique}) {
    MapRenderOptions options;
    options.view = view;
    const auto start = std::chrono::steady_clock::now();
    StatusOr<std::string> png = RenderMapPng(in, options);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_TRUE(png.ok()) << png.status().ToString();
    std::cout << (view == RenderView::kTopDown ? "top-down" : "oblique") << ": " << seconds
              << " s, " << png->size() << " bytes\n";
    // Generous: sanitiser and debug builds are several times slower than release.
    EXPECT_LT(seconds, 10.0);
  }
}

}  // namespace
}  // namespace semmap
