// Template images of named objects, as a user would photograph one for an object database:
// the object's front face seen straight on, filling the picture but for a thin margin of
// whatever surrounds it in the scene.
#pragma once

#include <opencv2/core/mat.hpp>

#include "common/status.h"
#include "tests/testing/synth/renderer.h"
#include "tests/testing/synth/scene.h"

namespace semmap::synth {

struct TemplateOptions {
  double metres_per_pixel = 0.001;  // image resolution on the face
  double margin = 0.06;             // border on each side, as a fraction of the face's size
  double distance = 0.4;            // camera distance from the face, metres
};

// Renders `object.front` with `renderer`'s scene through a camera sized for the face (so the
// renderer's own camera does not matter). BGR8.
StatusOr<cv::Mat> RenderObjectTemplate(const Renderer& renderer, const NamedObject& object,
                                       const TemplateOptions& options = {});

}  // namespace semmap::synth
