// TUM RGB-D layout: rgb.txt and depth.txt (`timestamp path`), camera.yaml, and optionally
// groundtruth.txt (`timestamp tx ty tz qx qy qz qw`).
#pragma once

#include <cstdint>
#include <string>

#include "client/datasets/dataset.h"

namespace semmap {

// Colour and depth pair up when their stamps differ by less than this (TUM's associate.py).
inline constexpr int64_t kTumMaxAssociationNs = 20'000'000;  // 0.02 s

// Every colour image becomes a frame; depth.txt is optional (no depth_scale without it).
StatusOr<Dataset> OpenTumDataset(const std::string& dir);

}  // namespace semmap
