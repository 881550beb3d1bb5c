// Shared fixture of the recognition tests: the default synthetic room (seed 1), its renderer
// with the default 640x480 camera, one object model per named object built from the user-style
// photo of its front face (synth::RenderObjectTemplate), keyframe features as the odometry
// extracts them (default FeatureExtractorOptions, with depth), and the ground truth of which
// objects a view sees.
//
// Position truth: a detection's centre is the median of its inlier features' 3D points, and
// the features lie on the face the photo shows, so the truth is the centre of the object's
// front face (NamedObject::front.Centre()), not the centre of its bounding box (the book's is
// 2.25 cm behind its cover, the teddy cube's 20 cm). The comparison is made only for views
// that see the whole face (a partly visible face's features cluster on the visible part).
#pragma once

#include <Eigen/Geometry>
#include <vector>

#include "common/camera.h"
#include "core/odometry/feature_extractor.h"
#include "core/recognition/object_model.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/scene.h"

namespace semmap::recognition_test {

const synth::Scene& Room();
const synth::Renderer& RoomRenderer();  // DefaultSyntheticCamera()
const CameraCalibration& RoomCamera();

// Models of Room().objects, in order; type_id = index + 1, label = the object's.
const std::vector<ObjectModel>& RoomModels();
ObjectRecognitionOptions TestOptions();  // the defaults

struct Keyframe {
  Eigen::Isometry3d T_world_camera = Eigen::Isometry3d::Identity();
  synth::RenderedFrame frame;
  FrameFeatures features;
};

// Renders the view and extracts its features (aborts the test process on an error: the
// fixture is known good).
Keyframe MakeKeyframe(const Eigen::Isometry3d& T_world_camera);
// Extracts features of an already rendered (possibly edited) frame.
FrameFeatures ExtractFeatures(const synth::RenderedFrame& frame);

// Fraction in [0, 1] of a 9 x 9 grid of points on `object`'s front face that the view sees:
// the face turned towards the camera (within 75 degrees of head-on), the point in front of the
// camera, inside the image and not hidden (the rendered depth there within 1 cm of the
// point's).
double VisibleFraction(const synth::NamedObject& object, const Eigen::Isometry3d& T_world_camera,
                       const synth::RenderedFrame& frame);

// The shorter of the front face's projected width and height in pixels (0 when a corner is
// behind the camera).
double ProjectedFaceMinSidePx(const synth::NamedObject& object,
                              const Eigen::Isometry3d& T_world_camera);

// A camera `distance` metres from the centre of `object`'s front face, looking at it: on the
// face's normal turned by `yaw_offset` radians about the vertical, `height_offset` metres
// higher.
Eigen::Isometry3d FacingPose(const synth::NamedObject& object, double distance,
                             double yaw_offset = 0.0, double height_offset = 0.0);

}  // namespace semmap::recognition_test
