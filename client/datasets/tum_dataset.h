// TUM RGB-D layout: rgb.txt and depth.txt (`timestamp path`), camera.yaml, and optionally
// groundtruth.txt (`timestamp tx ty tz qx qy qz qw`).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "client/datasets/dataset.h"

namespace semmap {

// Colour and depth pair up when their stamps differ by less than this (TUM's associate.py).
inline constexpr int64_t kTumMaxAssociationNs = 20'000'000;  // 0.02 s

// One entry of rgb.txt / depth.txt.
struct TumListEntry {
  int64_t stamp_ns = 0;
  std::string path;  // as listed (relative to the dataset dir), blanks inside kept
  int line = 0;      // 1-based
};

// The content of rgb.txt / depth.txt: `timestamp path` per line (the path is the rest of the
// line), '#' lines are comments. In file order; listed files are not checked here. Errors name
// `path` (the list's file name or any label) and the line.
StatusOr<std::vector<TumListEntry>> ParseTumImageList(std::string_view content,
                                                      const std::string& path);

// Every colour image becomes a frame; depth.txt is optional (no depth_scale without it).
StatusOr<Dataset> OpenTumDataset(const std::string& dir);

}  // namespace semmap
