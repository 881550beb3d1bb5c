#include "core/odometry/internal/orb_keypoints.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <numeric>
#include <opencv2/imgproc.hpp>

namespace semmap::internal {
namespace {

constexpr int kFastRadius = 3;   // FAST's circle: no corner within 3 pixels of a Mat's edge
constexpr int kHarrisBlock = 7;  // cv::ORB's HARRIS_BLOCK_SIZE
constexpr float kHarrisK = 0.04f;

// Keeps the `n` keypoints of highest response (deterministic for a given input); the others go
// to the end of `dropped` when it is given.
void KeepStrongest(std::vector<cv::KeyPoint>* keypoints, int n,
                   std::vector<cv::KeyPoint>* dropped = nullptr) {
  if (static_cast<int>(keypoints->size()) <= n) return;
  const auto cut = keypoints->begin() + std::max(n, 0);
  std::nth_element(
      keypoints->begin(), cut, keypoints->end(),
      [](const cv::KeyPoint& a, const cv::KeyPoint& b) { return a.response > b.response; });
  if (dropped != nullptr) dropped->insert(dropped->end(), cut, keypoints->end());
  keypoints->resize(static_cast<size_t>(std::max(n, 0)));
}

bool Inside(const cv::Rect2f& r, float x, float y) {
  return x >= r.x && x < r.x + r.width && y >= r.y && y < r.y + r.height;
}

}  // namespace

OrbPyramid BuildOrbPyramid(const cv::Mat& grey, int levels, double scale_factor) {
  OrbPyramid pyramid;
  pyramid.levels.push_back(grey);
  pyramid.scales.push_back(1.0);
  for (int l = 1; l < levels; ++l) {
    const double scale = std::pow(scale_factor, l);
    const cv::Size size(static_cast<int>(std::lround(grey.cols / scale)),
                        static_cast<int>(std::lround(grey.rows / scale)));
    if (size.width <= 2 * kOrbEdge || size.height <= 2 * kOrbEdge) break;
    cv::Mat level;
    // From the level above, as cv::ORB builds its pyramid (the same pixels it describes).
    cv::resize(pyramid.levels.back(), level, size, 0, 0, cv::INTER_LINEAR_EXACT);
    pyramid.levels.push_back(std::move(level));
    pyramid.scales.push_back(scale);
  }
  return pyramid;
}

std::vector<int> OrbLevelBudgets(int total, int levels, double scale_factor) {
  std::vector<int> budgets(static_cast<size_t>(std::max(levels, 0)), 0);
  if (levels <= 0) return budgets;
  const double ratio = 1.0 / scale_factor;
  double share = total * (1.0 - ratio) / (1.0 - std::pow(ratio, levels));
  int assigned = 0;
  for (int l = 0; l + 1 < levels; ++l) {
    budgets[static_cast<size_t>(l)] = static_cast<int>(std::lround(share));
    assigned += budgets[static_cast<size_t>(l)];
    share *= ratio;
  }
  budgets.back() = std::max(total - assigned, 0);
  return budgets;
}

float HarrisResponse(const cv::Mat& image, cv::Point p) {
  // The 3 x 3 Sobel gradients of the block's pixels, row by row from row pointers: the same
  // integer sums as evaluating each pixel through Mat::at, without its address arithmetic.
  const int r = kHarrisBlock / 2;
  long long a = 0, b = 0, c = 0;
  for (int y = p.y - r; y <= p.y + r; ++y) {
    const uint8_t* above = image.ptr<uint8_t>(y - 1);
    const uint8_t* row = image.ptr<uint8_t>(y);
    const uint8_t* below = image.ptr<uint8_t>(y + 1);
    int sum_a = 0, sum_b = 0, sum_c = 0;  // at most 7 * 1020^2 each: fits an int
    for (int x = p.x - r; x <= p.x + r; ++x) {
      const int ix = (above[x + 1] - above[x - 1]) + 2 * (row[x + 1] - row[x - 1]) +
                     (below[x + 1] - below[x - 1]);
      const int iy =
          (below[x - 1] - above[x - 1]) + 2 * (below[x] - above[x]) + (below[x + 1] - above[x + 1]);
      sum_a += ix * ix;
      sum_b += iy * iy;
      sum_c += ix * iy;
    }
    a += sum_a;
    b += sum_b;
    c += sum_c;
  }
  // Gradients normalised to [-1, 1] per pixel and block (cv::ORB's scale), so responses of
  // different levels compare.
  const double scale = 1.0 / (4.0 * kHarrisBlock * 255.0);
  const double s2 = scale * scale, s4 = s2 * s2;
  const double da = static_cast<double>(a), db = static_cast<double>(b),
               dc = static_cast<double>(c);
  return static_cast<float>((da * db - dc * dc - kHarrisK * (da + db) * (da + db)) * s4);
}

std::vector<int> DiscHalfWidths(int radius) {
  // Row v of the disc spans |u| <= half[v]. Rows up to the 45-degree line are the rounded
  // circle; the rows beyond it mirror those columns, so the disc is the same turned by 90
  // degrees (rounding every row alone is not, and its centroid then leans towards the axes:
  // angles off by ~2 degrees on average from those the descriptors and the place-recognition
  // vocabulary were made with).
  const auto r = static_cast<size_t>(std::max(radius, 0));
  std::vector<int> half(r + 1, 0);
  const int diagonal = static_cast<int>(std::floor(radius * std::numbers::sqrt2 / 2 + 1));
  for (int v = 0; v <= std::min(diagonal, radius); ++v) {
    half[static_cast<size_t>(v)] =
        static_cast<int>(std::lround(std::sqrt(static_cast<double>(radius * radius - v * v))));
  }
  for (int v = radius; v > diagonal; --v) {
    int u = 0;  // the widest column whose (direct) row reaches v
    while (u + 1 <= diagonal && half[static_cast<size_t>(u) + 1] >= v) ++u;
    half[static_cast<size_t>(v)] = u;
  }
  return half;
}

float IntensityCentroidAngle(const cv::Mat& image, cv::Point p,
                             const std::vector<int>& half_widths) {
  // Rows v and -v are summed together.
  const int radius = static_cast<int>(half_widths.size()) - 1;
  long long m10 = 0, m01 = 0;
  const uint8_t* centre = image.ptr<uint8_t>(p.y) + p.x;
  for (int u = -radius; u <= radius; ++u) m10 += static_cast<long long>(u) * centre[u];
  const size_t step = image.step1();
  for (int v = 1; v <= radius; ++v) {
    const uint8_t* below = centre + static_cast<ptrdiff_t>(v * step);
    const uint8_t* above = centre - static_cast<ptrdiff_t>(v * step);
    const int half = half_widths[static_cast<size_t>(v)];
    int moment = 0, difference = 0;  // at most 31 * 15 * 510: fits an int
    for (int u = -half; u <= half; ++u) {
      moment += u * (below[u] + above[u]);
      difference += below[u] - above[u];
    }
    m10 += moment;
    m01 += static_cast<long long>(v) * difference;
  }
  double degrees =
      std::atan2(static_cast<double>(m01), static_cast<double>(m10)) * 180.0 / std::numbers::pi;
  if (degrees < 0) degrees += 360.0;
  return static_cast<float>(degrees >= 360.0 ? 0.0 : degrees);
}

float IntensityCentroidAngle(const cv::Mat& image, cv::Point p, int radius) {
  return IntensityCentroidAngle(image, p, DiscHalfWidths(radius));
}

void OrientOrbKeypoints(const OrbPyramid& pyramid, std::vector<cv::KeyPoint>* keypoints) {
  // Once, not per keypoint: its square roots were a third of orientation's time.
  static const std::vector<int> kHalfWidths = DiscHalfWidths(kOrbPatchSize / 2);
  for (cv::KeyPoint& k : *keypoints) {
    const size_t level = static_cast<size_t>(k.octave);
    if (level >= pyramid.levels.size()) continue;
    const double scale = pyramid.scales[level];
    const cv::Point p(static_cast<int>(std::lround(k.pt.x / scale)),
                      static_cast<int>(std::lround(k.pt.y / scale)));
    k.angle = IntensityCentroidAngle(pyramid.levels[level], p, kHalfWidths);
  }
}

std::vector<cv::KeyPoint> DetectOrbKeypoints(const OrbPyramid& pyramid, int threshold,
                                             const std::vector<int>& level_budgets,
                                             const std::vector<cv::Rect2f>& regions,
                                             std::vector<cv::KeyPoint>* passed_over) {
  std::vector<cv::KeyPoint> out;
  const size_t levels = std::min(pyramid.levels.size(), level_budgets.size());
  for (size_t l = 0; l < levels; ++l) {
    const cv::Mat& image = pyramid.levels[l];
    const double scale = pyramid.scales[l];
    const int budget = level_budgets[l];
    const cv::Rect interior(kOrbEdge, kOrbEdge, image.cols - 2 * kOrbEdge,
                            image.rows - 2 * kOrbEdge);
    if (budget <= 0 || interior.empty()) continue;
    // Level rectangles to search: the interior, or each region's footprint in it (with the
    // region it belongs to: a corner counts for the region holding its level-0 position, so
    // footprints that overlap never count one twice).
    struct Search {
      cv::Rect rect;
      const cv::Rect2f* region;  // null: the whole image
    };
    std::vector<Search> searches;
    if (regions.empty()) {
      searches.push_back({interior, nullptr});
    } else {
      for (const cv::Rect2f& r : regions) {
        const int x0 = static_cast<int>(std::floor(r.x / scale));
        const int y0 = static_cast<int>(std::floor(r.y / scale));
        const int x1 = static_cast<int>(std::ceil((r.x + r.width) / scale));
        const int y1 = static_cast<int>(std::ceil((r.y + r.height) / scale));
        const cv::Rect footprint = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1) & interior;
        if (!footprint.empty()) searches.push_back({footprint, &r});
      }
    }
    std::vector<cv::KeyPoint> found, here;
    const cv::Rect whole(0, 0, image.cols, image.rows);
    for (const Search& search : searches) {
      // FAST needs its circle's pixels around the searched ones.
      const cv::Rect& s = search.rect;
      const cv::Rect padded = cv::Rect(s.x - kFastRadius, s.y - kFastRadius,
                                       s.width + 2 * kFastRadius, s.height + 2 * kFastRadius) &
                              whole;
      here.clear();
      cv::FAST(image(padded), here, threshold, /*nonmaxSuppression=*/true);
      for (cv::KeyPoint& k : here) {
        k.pt.x += static_cast<float>(padded.x);
        k.pt.y += static_cast<float>(padded.y);
        if (!s.contains(cv::Point(static_cast<int>(k.pt.x), static_cast<int>(k.pt.y)))) continue;
        if (search.region != nullptr && !Inside(*search.region, static_cast<float>(k.pt.x * scale),
                                                static_cast<float>(k.pt.y * scale))) {
          continue;
        }
        found.push_back(k);
      }
    }
    const size_t first_passed_over = passed_over != nullptr ? passed_over->size() : 0;
    KeepStrongest(&found, 2 * budget, passed_over);
    std::vector<float> fast_score;
    if (passed_over != nullptr) {
      fast_score.reserve(found.size());
      for (const cv::KeyPoint& k : found) fast_score.push_back(k.response);
    }
    for (cv::KeyPoint& k : found) {
      k.response =
          HarrisResponse(image, cv::Point(static_cast<int>(k.pt.x), static_cast<int>(k.pt.y)));
    }
    if (passed_over != nullptr && found.size() > static_cast<size_t>(budget)) {
      // The same selection as KeepStrongest, done on indices to give the FAST scores back.
      std::vector<size_t> order(found.size());
      std::iota(order.begin(), order.end(), size_t{0});
      std::nth_element(order.begin(), order.begin() + budget, order.end(),
                       [&](size_t a, size_t b) { return found[a].response > found[b].response; });
      std::vector<cv::KeyPoint> kept;
      kept.reserve(static_cast<size_t>(budget));
      for (size_t r = 0; r < order.size(); ++r) {
        cv::KeyPoint k = found[order[r]];
        if (r < static_cast<size_t>(budget)) {
          kept.push_back(k);
        } else {
          k.response = fast_score[order[r]];
          passed_over->push_back(k);
        }
      }
      found = std::move(kept);
    } else {
      KeepStrongest(&found, budget);
    }
    if (passed_over != nullptr) {
      for (size_t i = first_passed_over; i < passed_over->size(); ++i) {
        (*passed_over)[i].octave = static_cast<int>(l);
      }
    }
    for (cv::KeyPoint& k : found) {
      k.octave = static_cast<int>(l);
      out.push_back(AtLevelZero(pyramid, k));
    }
  }
  return out;
}

cv::KeyPoint AtLevelZero(const OrbPyramid& pyramid, cv::KeyPoint k) {
  const double scale = pyramid.scales[static_cast<size_t>(k.octave)];
  k.pt.x = static_cast<float>(k.pt.x * scale);
  k.pt.y = static_cast<float>(k.pt.y * scale);
  k.size = static_cast<float>(kOrbPatchSize * scale);
  return k;
}

void KeepWithinLevelBudgets(const std::vector<cv::KeyPoint>& strong,
                            const std::vector<int>& level_budgets,
                            std::vector<cv::KeyPoint>* weak) {
  std::vector<float> responses;
  std::vector<cv::KeyPoint> kept;
  for (size_t l = 0; l < level_budgets.size(); ++l) {
    const int level = static_cast<int>(l);
    const size_t budget = static_cast<size_t>(std::max(level_budgets[l], 0));
    responses.clear();
    for (const cv::KeyPoint& k : strong) {
      if (k.octave == level) responses.push_back(k.response);
    }
    for (const cv::KeyPoint& k : *weak) {
      if (k.octave == level) responses.push_back(k.response);
    }
    if (budget == 0 || responses.empty()) continue;
    float cut = -std::numeric_limits<float>::infinity();
    if (responses.size() > budget) {
      std::nth_element(responses.begin(), responses.begin() + static_cast<ptrdiff_t>(budget - 1),
                       responses.end(), std::greater<>());
      cut = responses[budget - 1];
    }
    for (const cv::KeyPoint& k : *weak) {
      if (k.octave == level && k.response >= cut) kept.push_back(k);
    }
  }
  *weak = std::move(kept);
}

void DescribeOrbKeypoints(const OrbPyramid& pyramid, float scale_factor,
                          cv::Feature2D& one_level_orb, std::vector<cv::KeyPoint>* keypoints,
                          cv::Mat* descriptors) {
  std::vector<cv::KeyPoint>& all = *keypoints;
  std::vector<cv::Mat> rows(all.size());  // each keypoint's descriptor, empty when dropped
  for (size_t level = 0; level < pyramid.levels.size(); ++level) {
    // cv::ORB's getScale(): pow of the float factor in double, then float.
    const float inverse = 1.f / static_cast<float>(std::pow(static_cast<double>(scale_factor),
                                                            static_cast<double>(level)));
    std::vector<cv::KeyPoint> here;
    std::vector<size_t> index;
    for (size_t i = 0; i < all.size(); ++i) {
      if (all[i].octave != static_cast<int>(level)) continue;
      cv::KeyPoint k = all[i];
      k.pt = k.pt * inverse;
      k.size *= inverse;
      k.octave = 0;
      here.push_back(k);
      index.push_back(i);
    }
    if (here.empty()) continue;
    const std::vector<cv::KeyPoint> asked = here;
    cv::Mat described;
    one_level_orb.compute(pyramid.levels[level], here, described);
    // compute() keeps the order of what it keeps: match the survivors back by position.
    for (size_t j = 0, r = 0; j < asked.size() && r < here.size(); ++j) {
      if (asked[j].pt != here[r].pt) continue;  // dropped
      rows[index[j]] = described.row(static_cast<int>(r));
      ++r;
    }
  }
  std::vector<cv::KeyPoint> kept;
  kept.reserve(all.size());
  cv::Mat out(0, one_level_orb.descriptorSize(), one_level_orb.descriptorType());
  out.reserve(all.size());
  for (size_t i = 0; i < all.size(); ++i) {
    if (rows[i].empty()) continue;
    kept.push_back(all[i]);
    out.push_back(rows[i]);
  }
  all = std::move(kept);
  *descriptors = std::move(out);
}

}  // namespace semmap::internal
