// eval: trajectory evaluation (ATE and RPE as the TUM RGB-D benchmark tools, the KITTI odometry
// metric). Works on files only; no server is contacted.
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "client/cli/commands.h"
#include "client/datasets/trajectory_io.h"
#include "client/eval/ate.h"
#include "client/eval/kitti_metric.h"
#include "client/eval/plot.h"
#include "client/eval/rpe.h"

namespace semmap::cli {
namespace {

constexpr char kEvalUsage[] =
    "usage: semmap eval ate GT EST [--max-diff S] [--scale] [--plot FILE.png]\n"
    "                             [--plot-errors FILE.png] [--json]\n"
    "       semmap eval rpe GT EST [--delta D] [--delta-unit s|f] [--max-diff S] [--json]\n"
    "       semmap eval kitti GT EST [--lengths 100,200,...] [--json]\n"
    "  Compares an estimated trajectory EST with the ground truth GT.\n"
    "  ate, rpe: TUM files ('t tx ty tz qx qy qz qw'); numbers as the TUM RGB-D benchmark's\n"
    "            evaluate_ate.py / evaluate_rpe.py --fixed_delta compute them.\n"
    "  kitti:    KITTI pose files (12 numbers a line), the odometry devkit's t_rel / r_rel.\n"
    "  `semmap eval ate --help` (rpe, kitti) lists a metric's options.\n";

struct TumPair {
  std::vector<StampedPose> gt;
  std::vector<StampedPose> est;
};

StatusOr<TumPair> ReadTumPair(const std::string& gt_path, const std::string& est_path) {
  TumPair files;
  SEMMAP_ASSIGN_OR_RETURN(files.gt, ReadTumTrajectory(gt_path));
  SEMMAP_ASSIGN_OR_RETURN(files.est, ReadTumTrajectory(est_path));
  return files;
}

std::string Fixed(double v, int decimals = 6) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, v);
  return text;
}

nlohmann::json StatsJson(const ErrorStatistics& s) {
  return {{"rmse", s.rmse}, {"mean", s.mean}, {"median", s.median},
          {"std", s.std},   {"min", s.min},   {"max", s.max}};
}

void PrintStats(const std::string& prefix, const ErrorStatistics& s, const std::string& unit) {
  std::cout << prefix << ".rmse " << Fixed(s.rmse) << " " << unit << "\n"
            << prefix << ".mean " << Fixed(s.mean) << " " << unit << "\n"
            << prefix << ".median " << Fixed(s.median) << " " << unit << "\n"
            << prefix << ".std " << Fixed(s.std) << " " << unit << "\n"
            << prefix << ".min " << Fixed(s.min) << " " << unit << "\n"
            << prefix << ".max " << Fixed(s.max) << " " << unit << "\n";
}

void NoteDuplicates(size_t dropped, const std::string& path) {
  if (dropped == 0) return;
  std::cerr << "semmap: note: " << path << " has " << dropped
            << " pose(s) with a repeated stamp; the last pose of each stamp was used (as the TUM "
               "tools do)\n";
}

StatusOr<double> ParsePositive(const ArgParser& parser, const std::string& name, double fallback) {
  SEMMAP_ASSIGN_OR_RETURN(const double v, parser.GetDouble(name, fallback));
  if (!(v > 0)) return InvalidArgumentError("--" + name + " must be positive");
  return v;
}

int RunAte(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddFlag("max-diff", "S", "max |t_gt - t_est| of an associated pair, seconds (0.02)");
  parser.AddSwitch("scale", "align with a similarity (estimate the scale) and print the scale");
  parser.AddFlag("plot", "FILE.png", "draw the trajectories (top view) to a PNG");
  parser.AddFlag("plot-errors", "FILE.png", "draw the error of each pose over time to a PNG");
  const std::string usage =
      "usage: semmap eval ate GT EST [--max-diff S] [--scale] [--plot FILE.png]\n"
      "                             [--plot-errors FILE.png] [--json]\n"
      "  Absolute trajectory error (m) after aligning EST to GT, as the TUM RGB-D benchmark's\n"
      "  evaluate_ate.py: stamps associated greedily by smallest |dt| < max-diff, one to one;\n"
      "  rigid (Horn) alignment of the positions, or a similarity with --scale.\n";
  if (int rc = ParseSubcommand(parser, &context, argc, argv, usage, 2, 2, /*uses_server=*/false,
                               "expected two files, GT and EST");
      rc >= 0) {
    return rc;
  }
  AteOptions options;
  options.estimate_scale = parser.Has("scale");
  StatusOr<double> max_diff = ParsePositive(parser, "max-diff", options.max_difference_s);
  if (!max_diff.ok()) return ReportUsage(max_diff.status().message(), usage);
  options.max_difference_s = *max_diff;

  const std::string& gt_path = parser.positional()[0];
  const std::string& est_path = parser.positional()[1];
  StatusOr<TumPair> files = ReadTumPair(gt_path, est_path);
  if (!files.ok()) return ReportError(files.status());
  StatusOr<AteResult> ate = ComputeAte(files->gt, files->est, options);
  if (!ate.ok()) return ReportError(ate.status());
  NoteDuplicates(ate->gt_duplicates_dropped, gt_path);
  NoteDuplicates(ate->est_duplicates_dropped, est_path);

  if (parser.Has("plot")) {
    if (Status s = PlotTrajectory(*ate, parser.Get("plot")); !s.ok()) return ReportError(s);
  }
  if (parser.Has("plot-errors")) {
    if (Status s = PlotErrors(*ate, parser.Get("plot-errors")); !s.ok()) return ReportError(s);
  }

  const ErrorStatistics& s = ate->stats;
  if (context.json) {
    nlohmann::json out = {{"pairs", s.count},   {"rmse", s.rmse}, {"mean", s.mean},
                          {"median", s.median}, {"std", s.std},   {"min", s.min},
                          {"max", s.max}};
    if (options.estimate_scale) out["scale"] = ate->alignment.scale;
    PrintJson(out);
    return kExitOk;
  }
  // The lines evaluate_ate.py --verbose prints, so existing result parsers keep working.
  std::cout << "compared_pose_pairs " << s.count << " pairs\n";
  PrintStats("absolute_translational_error", s, "m");
  if (options.estimate_scale)
    std::cout << "alignment.scale " << Fixed(ate->alignment.scale) << "\n";
  return kExitOk;
}

int RunRpe(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddFlag("delta", "D", "distance of the compared poses (1)");
  parser.AddFlag("delta-unit", "s|f", "unit of delta: seconds or frames (s)");
  parser.AddFlag("max-diff", "S",
                 "max |dt| to the closest ground-truth stamp, seconds (2 x median GT interval)");
  const std::string usage =
      "usage: semmap eval rpe GT EST [--delta D] [--delta-unit s|f] [--max-diff S] [--json]\n"
      "  Relative pose error over pose pairs `delta` apart: translational (m) and rotational\n"
      "  (deg), as the TUM RGB-D benchmark's evaluate_rpe.py --fixed_delta --max_pairs 0.\n";
  if (int rc = ParseSubcommand(parser, &context, argc, argv, usage, 2, 2, /*uses_server=*/false,
                               "expected two files, GT and EST");
      rc >= 0) {
    return rc;
  }
  RpeOptions options;
  StatusOr<double> delta = ParsePositive(parser, "delta", options.delta);
  if (!delta.ok()) return ReportUsage(delta.status().message(), usage);
  options.delta = *delta;
  const std::string unit = parser.Get("delta-unit", "s");
  if (unit == "s") {
    options.unit = RpeDeltaUnit::kSeconds;
  } else if (unit == "f") {
    options.unit = RpeDeltaUnit::kFrames;
  } else {
    return ReportUsage("--delta-unit must be s or f, got '" + unit + "'", usage);
  }
  if (parser.Has("max-diff")) {
    StatusOr<double> max_diff = ParsePositive(parser, "max-diff", 0.02);
    if (!max_diff.ok()) return ReportUsage(max_diff.status().message(), usage);
    options.max_difference_s = *max_diff;
  }

  const std::string& gt_path = parser.positional()[0];
  const std::string& est_path = parser.positional()[1];
  StatusOr<TumPair> files = ReadTumPair(gt_path, est_path);
  if (!files.ok()) return ReportError(files.status());
  StatusOr<RpeResult> rpe = ComputeRpe(files->gt, files->est, options);
  if (!rpe.ok()) return ReportError(rpe.status());
  NoteDuplicates(rpe->gt_duplicates_dropped, gt_path);
  NoteDuplicates(rpe->est_duplicates_dropped, est_path);

  if (context.json) {
    PrintJson({{"pairs", rpe->pairs.size()},
               {"delta", options.delta},
               {"delta_unit", unit},
               {"max_diff", rpe->max_difference_s},
               {"translation_m", StatsJson(rpe->translation_m)},
               {"rotation_deg", StatsJson(rpe->rotation_deg)}});
    return kExitOk;
  }
  std::cout << "compared_pose_pairs " << rpe->pairs.size() << " pairs\n";
  PrintStats("translational_error", rpe->translation_m, "m");
  PrintStats("rotational_error", rpe->rotation_deg, "deg");
  return kExitOk;
}

StatusOr<std::vector<double>> ParseLengths(const std::string& text) {
  std::vector<double> lengths;
  size_t begin = 0;
  while (begin <= text.size()) {
    const size_t end = std::min(text.find(',', begin), text.size());
    const std::string item = text.substr(begin, end - begin);
    char* stop = nullptr;
    errno = 0;
    const double v = std::strtod(item.c_str(), &stop);
    if (item.empty() || *stop != '\0' || errno != 0 || !std::isfinite(v)) {
      return InvalidArgumentError("--lengths expects comma-separated metres, got '" + text + "'");
    }
    lengths.push_back(v);
    begin = end + 1;
  }
  return lengths;
}

int RunKitti(CliContext context, int argc, const char* const* argv) {
  ArgParser parser;
  parser.AddFlag("lengths", "L,L,...",
                 "segment lengths in metres (100,200,300,400,500,600,700,800)");
  const std::string usage =
      "usage: semmap eval kitti GT EST [--lengths 100,200,...] [--json]\n"
      "  The KITTI odometry metric (devkit): segments of each length along the ground truth,\n"
      "  starting every 10 frames; t_rel = translation error / length (%), r_rel = rotation\n"
      "  error / length (deg/100 m), averaged over all segments. Files in KITTI pose format with\n"
      "  the same number of poses.\n";
  if (int rc = ParseSubcommand(parser, &context, argc, argv, usage, 2, 2, /*uses_server=*/false,
                               "expected two files, GT and EST");
      rc >= 0) {
    return rc;
  }
  KittiOptions options;
  if (parser.Has("lengths")) {
    StatusOr<std::vector<double>> lengths = ParseLengths(parser.Get("lengths"));
    if (!lengths.ok()) return ReportUsage(lengths.status().message(), usage);
    options.lengths_m = *lengths;
    if (Status valid = options.Validate(); !valid.ok()) return ReportUsage(valid.message(), usage);
  }
  StatusOr<std::vector<StampedPose>> gt = ReadKittiPoses(parser.positional()[0]);
  if (!gt.ok()) return ReportError(gt.status());
  StatusOr<std::vector<StampedPose>> est = ReadKittiPoses(parser.positional()[1]);
  if (!est.ok()) return ReportError(est.status());
  StatusOr<KittiResult> kitti = ComputeKittiMetric(*gt, *est, options);
  if (!kitti.ok()) return ReportError(kitti.status());

  if (context.json) {
    nlohmann::json per_length = nlohmann::json::array();
    for (const KittiLengthStats& l : kitti->per_length) {
      per_length.push_back({{"length_m", l.length_m},
                            {"segments", l.segments},
                            {"t_rel", l.t_rel_percent},
                            {"r_rel", l.r_rel_deg_per_100m}});
    }
    PrintJson({{"segments", kitti->segments.size()},
               {"t_rel", kitti->t_rel_percent},
               {"r_rel", kitti->r_rel_deg_per_100m},
               {"t_err", kitti->t_err},
               {"r_err", kitti->r_err},
               {"gt_path_length_m", kitti->gt_path_length_m},
               {"lengths", per_length}});
    return kExitOk;
  }
  std::cout << "segments " << kitti->segments.size() << " (ground-truth path "
            << Fixed(kitti->gt_path_length_m, 1) << " m)\n"
            << "t_rel " << Fixed(kitti->t_rel_percent, 4) << " %        (t_err "
            << Fixed(kitti->t_err) << ")\n"
            << "r_rel " << Fixed(kitti->r_rel_deg_per_100m, 4) << " deg/100m (r_err "
            << Fixed(kitti->r_err, 8) << " rad/m)\n"
            << "length[m] segments  t_rel[%]  r_rel[deg/100m]\n";
  for (const KittiLengthStats& l : kitti->per_length) {
    char line[128];
    std::snprintf(line, sizeof(line), "%9.0f %8zu %9.4f %16.4f\n", l.length_m, l.segments,
                  l.t_rel_percent, l.r_rel_deg_per_100m);
    std::cout << line;
  }
  return kExitOk;
}

}  // namespace

// The commands' common signature (the others apply their flags to their copy of the context).
int RunEval(CliContext context,  // NOLINT(performance-unnecessary-value-param)
            int argc, const char* const* argv) {
  if (argc < 1) return ReportUsage("eval needs a metric: ate, rpe or kitti", kEvalUsage);
  const std::string metric = argv[0];
  if (metric == "--help" || metric == "-h" || metric == "help") {
    std::cout << kEvalUsage;
    return kExitOk;
  }
  if (metric == "ate") return RunAte(context, argc - 1, argv + 1);
  if (metric == "rpe") return RunRpe(context, argc - 1, argv + 1);
  if (metric == "kitti") return RunKitti(context, argc - 1, argv + 1);
  return ReportUsage("unknown metric '" + metric + "' (ate, rpe or kitti)", kEvalUsage);
}

}  // namespace semmap::cli
