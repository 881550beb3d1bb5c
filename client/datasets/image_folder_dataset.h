// A plain folder of images with a camera.yaml: a phone video's frames, a webcam's captures.
// Frames are the folder's .png / .jpg / .jpeg files in name order (zero-padded names sort in
// time order), stamped at camera.yaml's fps (30 when it gives none) from t = 0. No depth, no
// ground truth: MONO sessions.
#pragma once

#include <string>

#include "client/datasets/dataset.h"

namespace semmap {

// INVALID_ARGUMENT when the folder holds no images; camera.yaml's errors name their line.
StatusOr<Dataset> OpenImageFolderDataset(const std::string& dir);

}  // namespace semmap
