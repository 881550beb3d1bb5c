// ORB keypoint detection done once per frame instead of through cv::ORB::detect: one image
// pyramid, FAST per level, the weak-threshold pass only inside the grid cells that need it.
// The keypoints are what cv::ORB::detect gives (level-0 coordinates, octave, patch size, Harris
// response, intensity-centroid angle), so cv::ORB::compute describes them unchanged and the
// trained place-recognition vocabulary stays valid.
//
// Why not cv::ORB::detect: it runs FAST over every level of the whole image for each threshold,
// so the weak pass (faint or blurred cells) cost a second full detection, the largest part of
// tracking's time.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <vector>

namespace semmap::internal {

// Keypoints closer than this to a level's border are not detected (cv::ORB's edgeThreshold as
// the extractor has always set it): the descriptor's rotated patch must fit.
inline constexpr int kOrbEdge = 19;
inline constexpr int kOrbPatchSize = 31;

struct OrbPyramid {
  std::vector<cv::Mat> levels;  // levels[0] is the image itself (shared, not copied)
  std::vector<double> scales;   // scale_factor^level: a level pixel is this many level-0 ones
};

// `grey`: CV_8UC1. Levels smaller than the detection border are left out.
OrbPyramid BuildOrbPyramid(const cv::Mat& grey, int levels, double scale_factor);

// cv::ORB's split of a total over the levels: a geometric series with ratio 1 / scale_factor,
// the rest to the last level.
std::vector<int> OrbLevelBudgets(int total, int levels, double scale_factor);

// FAST corners at `threshold` (with non-maximum suppression) in every level, inside `regions`
// (level-0 rectangles, half-open; the whole image when empty; a corner belongs to the region
// holding its level-0 position, so adjacent regions never share one). Per level, the 2 * budget
// strongest by FAST score are scored by Harris and the `budget` best kept, as cv::ORB does. Angles
// are left at -1: orient only the keypoints kept (OrientOrbKeypoints), half the cost.
// `passed_over` (may be null) receives the corners found but not kept, in their level's pixel
// coordinates, with their level as octave and their FAST score as response.
std::vector<cv::KeyPoint> DetectOrbKeypoints(const OrbPyramid& pyramid, int threshold,
                                             const std::vector<int>& level_budgets,
                                             const std::vector<cv::Rect2f>& regions,
                                             std::vector<cv::KeyPoint>* passed_over = nullptr);

// A corner found in its level (`octave` set, level pixels) as detection gives it: level-0 pixels
// and ORB's patch size at that level.
cv::KeyPoint AtLevelZero(const OrbPyramid& pyramid, cv::KeyPoint k);

// Harris corner response (k = 0.04) over a 7 x 7 block of 3 x 3 Sobel gradients at `p`, scaled
// as cv::ORB scales it; `p` at least 4 pixels inside `image`.
float HarrisResponse(const cv::Mat& image, cv::Point p);

// Orientation in degrees [0, 360) of the intensity centroid of the disc of `radius` around
// `p` (Rublee et al.'s ORB), `p` at least `radius` pixels inside `image`.
float IntensityCentroidAngle(const cv::Mat& image, cv::Point p, int radius);
// The same with the disc given as DiscHalfWidths(radius): row v spans columns -w[v]..w[v].
float IntensityCentroidAngle(const cv::Mat& image, cv::Point p,
                             const std::vector<int>& half_widths);
std::vector<int> DiscHalfWidths(int radius);

// Sets each keypoint's angle (cv::ORB's orientation) from its level of `pyramid`; keypoints of
// DetectOrbKeypoints on that pyramid.
void OrientOrbKeypoints(const OrbPyramid& pyramid, std::vector<cv::KeyPoint>* keypoints);

// cv::ORB::compute()'s descriptors of `keypoints` (DetectOrbKeypoints on `pyramid`, oriented)
// without the pyramid it would build again: each level's keypoints described on that level by
// `one_level_orb` (cv::ORB with nlevels 1 and the extractor's other settings), their centres
// computed in float as cv::ORB computes them (pt * (1 / float(scale_factor^level))), so the bits
// are the same; about 30 % of compute()'s time saved. Keypoints a level cannot describe (too near
// its border) are dropped; the rest keep their order, aligned with the descriptor rows.
// `scale_factor` as the ORB objects were given it (a float).
void DescribeOrbKeypoints(const OrbPyramid& pyramid, float scale_factor,
                          cv::Feature2D& one_level_orb, std::vector<cv::KeyPoint>* keypoints,
                          cv::Mat* descriptors);

// Of `weak` (a second detection at a lower threshold in some regions), keeps those that rank
// within their level's budget among `strong` and `weak` together by response: the ones a
// whole-image detection at the lower threshold would have kept there, so a weak pass in a few
// cells adds what the two full detections it replaces added, no more.
void KeepWithinLevelBudgets(const std::vector<cv::KeyPoint>& strong,
                            const std::vector<int>& level_budgets, std::vector<cv::KeyPoint>* weak);

}  // namespace semmap::internal
