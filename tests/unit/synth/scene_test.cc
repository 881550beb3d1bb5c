#include "tests/testing/synth/scene.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <set>

#include "tests/testing/synth/default_scene.h"
#include "tests/unit/synth/synth_test_util.h"

namespace semmap::synth {
namespace {

using Eigen::Vector3d;
using test::DefaultScene;

TEST(SceneTest, MakeSurfaceFacesItsNormalWithTheTextureUpright) {
  const Surface s = MakeSurface({3, 0, 1.4}, -Vector3d::UnitX(), Vector3d::UnitZ(), 5.0, 2.8, 0);
  EXPECT_TRUE(s.Normal().isApprox(-Vector3d::UnitX()));
  EXPECT_TRUE(s.Centre().isApprox(Vector3d(3, 0, 1.4)));
  EXPECT_TRUE(s.v_axis.isApprox(-Vector3d::UnitZ()));  // rows run down
  // Facing the wall from the room (looking +x, z up), the viewer's right is -y.
  EXPECT_TRUE(s.u_axis.isApprox(-Vector3d::UnitY()));
  EXPECT_TRUE(s.origin.isApprox(Vector3d(3, 2.5, 2.8)));  // top-left as the viewer sees it
}

TEST(SceneTest, BoxFacesPointOutwardsAndTileTheBox) {
  Box box;
  box.T_world_box.linear() =
      Eigen::AngleAxisd(0.3, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  box.T_world_box.translation() = Vector3d(1, 2, 3);
  box.size = Vector3d(0.4, 0.6, 0.8);
  double area = 0;
  for (int f = 0; f < 6; ++f) {
    const Surface s = BoxFaceSurface(box, static_cast<BoxFace>(f));
    const Vector3d out = s.Centre() - box.T_world_box.translation();
    EXPECT_GT(out.dot(s.Normal()), 0.19) << "face " << f;
    EXPECT_NEAR(std::abs(s.u_axis.dot(s.v_axis)), 0.0, 1e-12);
    area += s.width * s.height;
  }
  EXPECT_NEAR(area, 2 * (0.4 * 0.6 + 0.4 * 0.8 + 0.6 * 0.8), 1e-12);
  const Eigen::AlignedBox3d bounds = WorldBounds(box);
  EXPECT_TRUE(bounds.center().isApprox(Vector3d(1, 2, 3)));
}

TEST(SceneTest, ValidateSceneCatchesMistakes) {
  Scene scene;
  scene.room = Eigen::AlignedBox3d(Vector3d::Zero(), Vector3d(4, 4, 3));
  const int t = scene.AddTexture(cv::Mat(8, 8, CV_8UC3, cv::Scalar::all(100)));
  scene.surfaces.push_back(MakeSurface({2, 2, 0}, Vector3d::UnitZ(), Vector3d::UnitY(), 4, 4, t));
  EXPECT_TRUE(ValidateScene(scene).ok());

  Scene bad = scene;
  bad.surfaces[0].texture = 3;
  EXPECT_EQ(ValidateScene(bad).code(), StatusCode::kInvalidArgument);
  bad = scene;
  bad.surfaces[0].u_axis = Vector3d(1, 1, 0);
  EXPECT_FALSE(ValidateScene(bad).ok());
  bad = scene;
  bad.surfaces[0].width = 0;
  EXPECT_FALSE(ValidateScene(bad).ok());
  bad = scene;
  bad.textures[0] = cv::Mat(8, 8, CV_8UC1);
  EXPECT_FALSE(ValidateScene(bad).ok());
  bad = scene;
  bad.boxes.push_back(Box{});  // zero size, no textures
  EXPECT_FALSE(ValidateScene(bad).ok());
  bad = scene;
  NamedObject object{"a b", Vector3d::Zero(), Vector3d::Ones(), scene.surfaces[0]};
  bad.objects.push_back(object);
  EXPECT_FALSE(ValidateScene(bad).ok());  // blank in the label
  bad.objects[0].label = "cup";
  EXPECT_TRUE(ValidateScene(bad).ok());
  bad.objects.push_back(bad.objects[0]);
  EXPECT_FALSE(ValidateScene(bad).ok());  // repeated label
  bad = scene;
  bad.room = Eigen::AlignedBox3d();
  EXPECT_FALSE(ValidateScene(bad).ok());
}

TEST(DefaultSceneTest, IsTheDocumentedRoom) {
  const Scene& scene = DefaultScene();
  EXPECT_TRUE(ValidateScene(scene).ok());
  EXPECT_TRUE(scene.room.min().isApprox(Vector3d(-3, -2.5, 0)));
  EXPECT_TRUE(scene.room.max().isApprox(Vector3d(3, 2.5, 2.8)));
  EXPECT_EQ(scene.surfaces.size(), 7u);  // 4 walls, floor, ceiling, poster
  // 4 furniture boxes + book, laptop base and lid, teddy box.
  EXPECT_EQ(scene.boxes.size(), 8u);
  std::set<std::string> labels;
  for (const NamedObject& o : scene.objects) labels.insert(o.label);
  EXPECT_EQ(labels, (std::set<std::string>{"book", "laptop", "mug_poster", "teddy_box"}));
}

TEST(DefaultSceneTest, EverythingIsInsideTheRoomAndObjectsFaceItsMiddle) {
  const Scene& scene = DefaultScene();
  const Eigen::AlignedBox3d room = scene.room;
  for (const Box& box : scene.boxes) EXPECT_TRUE(room.contains(WorldBounds(box)));
  for (const NamedObject& o : scene.objects) {
    SCOPED_TRACE(o.label);
    const Eigen::AlignedBox3d bounds(o.centre - o.size / 2, o.centre + o.size / 2);
    EXPECT_TRUE(room.contains(bounds));
    // The front face lies on the object's bounds and looks towards the room's middle.
    EXPECT_LT(bounds.exteriorDistance(o.front.Centre()), 1e-9);
    const Vector3d to_middle = (Vector3d(0, 0, 1.3) - o.front.Centre()).normalized();
    EXPECT_GT(o.front.Normal().dot(to_middle), 0.5);
    EXPECT_GT(o.front.width * o.front.height, 0.04);  // at least 20 x 20 cm
  }
  // The camera zone (|x| < 2, |y| < 1.4) is free of furniture.
  const Eigen::AlignedBox3d zone(Vector3d(-2, -1.4, 0), Vector3d(2, 1.4, 2.8));
  for (const Box& box : scene.boxes) EXPECT_FALSE(zone.intersects(WorldBounds(box)));
}

TEST(DefaultSceneTest, SeedChangesTexturesButNotLayout) {
  StatusOr<Scene> again = MakeDefaultRoomScene(1);
  StatusOr<Scene> other = MakeDefaultRoomScene(2);
  ASSERT_TRUE(again.ok() && other.ok());
  const Scene& scene = DefaultScene();
  ASSERT_EQ(again->textures.size(), scene.textures.size());
  ASSERT_EQ(other->textures.size(), scene.textures.size());
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    EXPECT_EQ(cv::norm(scene.textures[i], again->textures[i], cv::NORM_INF), 0) << i;
    EXPECT_GT(
        cv::norm(scene.textures[i], other->textures[i], cv::NORM_L1) / scene.textures[i].total(),
        20.0)
        << i;
  }
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    EXPECT_TRUE(other->objects[i].centre.isApprox(scene.objects[i].centre));
  }
}

TEST(DefaultSceneTest, TexturesAreDistinctPerSurface) {
  // No two textures of a scene share content (each comes from its own seed).
  const Scene& scene = DefaultScene();
  for (size_t i = 0; i < scene.textures.size(); ++i) {
    for (size_t j = i + 1; j < scene.textures.size(); ++j) {
      const cv::Mat& a = scene.textures[i];
      const cv::Mat& b = scene.textures[j];
      const cv::Rect roi(0, 0, std::min(a.cols, b.cols), std::min(a.rows, b.rows));
      EXPECT_GT(cv::norm(a(roi), b(roi), cv::NORM_L1) / roi.area(), 20.0) << i << " " << j;
    }
  }
}

}  // namespace
}  // namespace semmap::synth
