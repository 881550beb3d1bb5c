// semmap-synth: renders a synthetic RGB-D sequence of the default textured room (furniture,
// named objects) along a camera trajectory and writes it in the TUM RGB-D layout with ground
// truth, camera.yaml, objects.txt and object templates.
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <string>

#include "common/arg_parser.h"
#include "tests/testing/synth/default_scene.h"
#include "tests/testing/synth/sequence_writer.h"
#include "tests/testing/synth/trajectory.h"

namespace {

using namespace semmap;
using namespace semmap::synth;

constexpr int kExitOk = 0, kExitError = 1, kExitUsage = 2;
constexpr double kColourNoiseSigma = 3.0;  // 8-bit levels
constexpr int kBlurSamples = 24;           // at most; about one render per pixel of motion

struct Config {
  std::string out_dir;
  TrajectoryKind trajectory = TrajectoryKind::kCircle;
  TrajectoryOptions trajectory_options;
  uint64_t seed = 1;
  SequenceOptions sequence;
  bool quiet = false;
};

ArgParser MakeParser() {
  ArgParser p;
  p.AddFlag(
      "trajectory", "KIND",
      "circle | figure8 | corridor | rotation | fast | tour (the named objects, each from 1 m) "
      "(default circle)");
  p.AddFlag("frames", "N", "number of frames (default 300; loops make --laps laps over them)");
  p.AddFlag("laps", "N", "laps of a loop trajectory over the frames (default 1)");
  p.AddFlag("rate", "HZ", "frame rate, sets the stamps (default 30)");
  p.AddFlag("seed", "S", "scene textures, fast-motion path and noise (default 1)");
  p.AddFlag("width", "W", "image width (default 640)");
  p.AddFlag("height", "H", "image height (default 480)");
  p.AddFlag("fx", "PX", "focal length x (default 525 * W / 640)");
  p.AddFlag("fy", "PX", "focal length y (default fx)");
  p.AddFlag("cx", "PX", "principal point x (default W / 2 - 0.5)");
  p.AddFlag("cy", "PX", "principal point y (default H / 2 - 0.5)");
  p.AddSwitch("depth-noise", "Kinect-like depth noise, sigma = 1.2 mm + 1.9 mm/m^2 (z - 0.4)^2");
  p.AddSwitch("colour-noise", "Gaussian colour noise, sigma 3 levels");
  p.AddSwitch("blur", "motion blur over half the frame interval");
  p.AddFlag("drop-depth", "P", "drop each depth pixel with probability P (0..1)");
  p.AddSwitch("no-templates", "do not write objects/<label>.png templates");
  p.AddSwitch("quiet", "no progress output");
  p.AddSwitch("help", "this help");
  return p;
}

std::string Usage(const ArgParser& parser) {
  return "usage: semmap-synth OUT_DIR [options]\n"
         "\n"
         "Renders a synthetic RGB-D sequence of a textured 6 x 5 x 2.8 m room with furniture and\n"
         "named objects (book, laptop, mug_poster, teddy_box) and writes it to OUT_DIR (created;\n"
         "must be empty) in the TUM RGB-D layout: rgb/, depth/ (16-bit PNG, 5000 per metre),\n"
         "rgb.txt, depth.txt, groundtruth.txt, camera.yaml, objects.txt, objects/<label>.png.\n"
         "Deterministic given the seed. Exit status: 0 ok, 1 error, 2 usage.\n"
         "\n"
         "options:\n" +
         parser.Usage();
}

// An integer flag within [lo, hi].
semmap::Status GetIntIn(const ArgParser& p, const std::string& name, long long fallback,
                        long long lo, long long hi, long long* out) {
  SEMMAP_ASSIGN_OR_RETURN(*out, p.GetInt(name, fallback));
  if (*out < lo || *out > hi) {
    return InvalidArgumentError("--" + name + " must be in " + std::to_string(lo) + ".." +
                                std::to_string(hi) + ", got " + std::to_string(*out));
  }
  return OkStatus();
}

semmap::Status ParseConfig(const ArgParser& p, Config* config) {
  if (p.positional().size() != 1) {
    return InvalidArgumentError(p.positional().empty() ? "missing OUT_DIR"
                                                       : "expected one OUT_DIR, got " +
                                                             std::to_string(p.positional().size()));
  }
  config->out_dir = p.positional()[0];
  SEMMAP_ASSIGN_OR_RETURN(config->trajectory, ParseTrajectoryKind(p.Get("trajectory", "circle")));
  long long frames = 0, laps = 0, seed = 0, width = 0, height = 0;
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "frames", 300, 1, 1'000'000, &frames));
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "laps", 1, 1, 1000, &laps));
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "seed", 1, 0, 0x7FFFFFFFFFFFFFFFLL, &seed));
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "width", 640, 16, 8192, &width));
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "height", 480, 16, 8192, &height));
  SEMMAP_ASSIGN_OR_RETURN(const double rate, p.GetDouble("rate", 30.0));

  config->seed = static_cast<uint64_t>(seed);
  config->trajectory_options.frames = static_cast<int>(frames);
  config->trajectory_options.laps = static_cast<int>(laps);
  config->trajectory_options.rate_hz = rate;
  config->trajectory_options.seed = config->seed;

  CameraCalibration camera =
      DefaultSyntheticCamera(static_cast<int>(width), static_cast<int>(height));
  SEMMAP_ASSIGN_OR_RETURN(camera.fx, p.GetDouble("fx", camera.fx));
  SEMMAP_ASSIGN_OR_RETURN(camera.fy, p.GetDouble("fy", camera.fx));
  SEMMAP_ASSIGN_OR_RETURN(camera.cx, p.GetDouble("cx", camera.cx));
  SEMMAP_ASSIGN_OR_RETURN(camera.cy, p.GetDouble("cy", camera.cy));
  if (Status valid = ValidateCalibration(camera); !valid.ok()) return valid.WithContext("camera");
  config->sequence.camera = camera;

  NoiseOptions& noise = config->sequence.noise;
  noise.depth_noise = p.Has("depth-noise");
  noise.colour_noise_sigma = p.Has("colour-noise") ? kColourNoiseSigma : 0.0;
  noise.motion_blur_samples = p.Has("blur") ? kBlurSamples : 0;
  SEMMAP_ASSIGN_OR_RETURN(noise.drop_depth_probability, p.GetDouble("drop-depth", 0.0));
  SEMMAP_RETURN_IF_ERROR(ValidateNoiseOptions(noise));
  config->sequence.noise_seed = config->seed;
  config->sequence.write_object_templates = !p.Has("no-templates");
  config->quiet = p.Has("quiet");
  return OkStatus();
}

int Run(const Config& config) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  auto seconds_since = [](Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
  };
  StatusOr<Scene> scene = MakeDefaultRoomScene(config.seed);
  if (!scene.ok()) {
    std::cerr << "semmap-synth: " << scene.status().ToString() << "\n";
    return kExitError;
  }
  TrajectoryOptions trajectory_options = config.trajectory_options;
  for (const NamedObject& object : scene->objects) {  // the tour's stops
    trajectory_options.tour_targets.push_back({object.front.Centre(), object.front.Normal()});
  }
  StatusOr<std::vector<StampedPose>> trajectory =
      MakeTrajectory(config.trajectory, scene->room, trajectory_options);
  if (!trajectory.ok()) {
    std::cerr << "semmap-synth: " << trajectory.status().ToString() << "\n";
    return kExitError;
  }
  SequenceOptions options = config.sequence;
  const auto render_start = Clock::now();
  if (!config.quiet) {
    std::fprintf(stderr, "semmap-synth: scene ready in %.2f s; rendering %zu frames to %s\n",
                 seconds_since(start), trajectory->size(), config.out_dir.c_str());
    options.progress = [&, last_decile = size_t{0}](size_t done, size_t total) mutable {
      const size_t decile = done * 10 / total;
      if (decile == last_decile && done != total) return;
      last_decile = decile;
      std::fprintf(stderr, "semmap-synth: %zu/%zu frames (%.1f frames/s)\n", done, total,
                   done / std::max(1e-9, seconds_since(render_start)));
    };
  }
  const Status written = WriteTumSequence(config.out_dir, *scene, *trajectory, options);
  if (!written.ok()) {
    std::cerr << "semmap-synth: " << written.ToString() << "\n";
    return kExitError;
  }
  const CameraCalibration& c = options.camera;
  std::printf("wrote %zu frames (%s, %dx%d, seed %llu) to %s in %.1f s\n", trajectory->size(),
              std::string(TrajectoryKindName(config.trajectory)).c_str(), c.width, c.height,
              static_cast<unsigned long long>(config.seed), config.out_dir.c_str(),
              seconds_since(start));
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  ArgParser parser = MakeParser();
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--help") == 0 || std::strcmp(argv[i], "-h") == 0) {
      std::cout << Usage(parser);
      return kExitOk;
    }
  }
  Config config;
  Status parsed = parser.Parse(argc, argv);
  if (parsed.ok()) parsed = ParseConfig(parser, &config);
  if (!parsed.ok()) {
    std::cerr << "semmap-synth: " << parsed.message() << "\n\n" << Usage(parser);
    return kExitUsage;
  }
  return Run(config);
}
