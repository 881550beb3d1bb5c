// semmap-train-vocab: trains the bag-of-words vocabulary for place recognition on the ORB
// features of one or more datasets, extracted as tracking extracts them, and saves it.
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "client/datasets/dataset.h"
#include "common/arg_parser.h"
#include "common/sha256.h"
#include "core/odometry/feature_extractor.h"
#include "core/slam/bow_vocabulary.h"

namespace {

using namespace semmap;

constexpr int kExitOk = 0, kExitError = 1, kExitUsage = 2;

struct Config {
  std::vector<std::string> datasets;
  std::string out_path;
  BowTrainingOptions training;
  FeatureExtractorOptions features;  // the tracking defaults but for the budget
  int every = 1;
  bool quiet = false;
};

ArgParser MakeParser() {
  ArgParser p;
  p.AddFlag("o", "FILE", "output vocabulary (required; parent directories are created)");
  p.AddFlag("k", "K", "branching factor (default 10)");
  p.AddFlag("levels", "L", "tree depth; up to K^L words (default 4)");
  p.AddFlag("every", "N", "use every Nth frame of each dataset (default 1)");
  p.AddFlag("max-features", "N", "ORB features per frame (default 1000, as tracking)");
  p.AddFlag("seed", "S", "k-means++ seeding; training is deterministic given it (default 1)");
  p.AddFlag("max-iterations", "N", "k-majority rounds per node at most (default 15)");
  p.AddSwitch("quiet", "no progress output");
  p.AddSwitch("help", "this help");
  return p;
}

std::string Usage(const ArgParser& parser) {
  return "usage: semmap-train-vocab DATASET_DIR... -o FILE [options]\n"
         "\n"
         "Extracts ORB features (semmap's FeatureExtractor with the tracking defaults) from every\n"
         "Nth frame of each dataset (TUM RGB-D or KITTI layout), trains a K^L bag-of-binary-words\n"
         "vocabulary tree (k-majority, k-means++ seeding, TF-IDF weights) and saves it to FILE.\n"
         "Exit status: 0 ok, 1 error, 2 usage.\n"
         "\n"
         "options (--k may also be written -k):\n" +
         parser.Usage();
}

Status GetIntIn(const ArgParser& p, const std::string& name, long long fallback, long long lo,
                long long hi, long long* out) {
  SEMMAP_ASSIGN_OR_RETURN(*out, p.GetInt(name, fallback));
  if (*out < lo || *out > hi) {
    return InvalidArgumentError("--" + name + " must be in " + std::to_string(lo) + ".." +
                                std::to_string(hi) + ", got " + std::to_string(*out));
  }
  return OkStatus();
}

Status ParseConfig(const ArgParser& p, Config* config) {
  if (p.positional().empty()) return InvalidArgumentError("missing DATASET_DIR");
  config->datasets = p.positional();
  config->out_path = p.Get("o");
  if (config->out_path.empty()) return InvalidArgumentError("missing -o FILE");
  long long k = 0, levels = 0, every = 0, max_features = 0, seed = 0, iterations = 0;
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "k", 10, 2, 255, &k));
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "levels", 4, 1, 16, &levels));
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "every", 1, 1, 1'000'000, &every));
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "max-features", 1000, 1, 100'000, &max_features));
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "seed", 1, 0, 0x7FFFFFFFFFFFFFFFLL, &seed));
  SEMMAP_RETURN_IF_ERROR(GetIntIn(p, "max-iterations", 15, 1, 1000, &iterations));
  config->training.branching = static_cast<int>(k);
  config->training.levels = static_cast<int>(levels);
  config->training.seed = static_cast<uint64_t>(seed);
  config->training.max_iterations = static_cast<int>(iterations);
  SEMMAP_RETURN_IF_ERROR(config->training.Validate());
  config->every = static_cast<int>(every);
  config->features.max_features = static_cast<int>(max_features);
  SEMMAP_RETURN_IF_ERROR(config->features.Validate());
  config->quiet = p.Has("quiet");
  return OkStatus();
}

using Clock = std::chrono::steady_clock;
double SecondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Appends the ORB descriptors of every Nth frame of one dataset to `sets`.
Status ExtractDataset(const Config& config, const std::string& dir, std::vector<cv::Mat>* sets,
                      size_t* descriptors) {
  SEMMAP_ASSIGN_OR_RETURN(const Dataset dataset, OpenDataset(dir));
  SEMMAP_ASSIGN_OR_RETURN(const FeatureExtractor extractor,
                          FeatureExtractor::Create(config.features, dataset.camera));
  const size_t total = (dataset.frames.size() + static_cast<size_t>(config.every) - 1) /
                       static_cast<size_t>(config.every);
  const auto start = Clock::now();
  size_t done = 0, last_decile = 0;
  for (size_t i = 0; i < dataset.frames.size(); i += static_cast<size_t>(config.every)) {
    const std::string& path = dataset.frames[i].colour_path;
    const cv::Mat image =
        cv::imread(path, dataset.colour_is_grey ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
    if (image.empty()) return UnavailableError("cannot decode " + path);
    // Depth only adds 3D points; the descriptors do not depend on it.
    SEMMAP_ASSIGN_OR_RETURN(FrameFeatures f, extractor.Extract(image, cv::Mat(), 0));
    *descriptors += static_cast<size_t>(f.descriptors.rows);
    sets->push_back(std::move(f.descriptors));
    ++done;
    const size_t decile = done * 10 / total;
    if (!config.quiet && (decile != last_decile || done == total)) {
      last_decile = decile;
      std::fprintf(stderr, "semmap-train-vocab: %s: %zu/%zu frames (%.1f frames/s)\n", dir.c_str(),
                   done, total, done / std::max(1e-9, SecondsSince(start)));
    }
  }
  return OkStatus();
}

int Run(const Config& config) {
  const auto start = Clock::now();
  std::vector<cv::Mat> sets;
  size_t descriptors = 0;
  for (const std::string& dir : config.datasets) {
    if (Status s = ExtractDataset(config, dir, &sets, &descriptors); !s.ok()) {
      std::cerr << "semmap-train-vocab: " << s.ToString() << "\n";
      return kExitError;
    }
  }
  const double extract_s = SecondsSince(start);
  if (!config.quiet) {
    std::fprintf(stderr,
                 "semmap-train-vocab: %zu descriptors from %zu images in %.1f s; training\n",
                 descriptors, sets.size(), extract_s);
  }
  BowTrainingOptions training = config.training;
  const auto train_start = Clock::now();
  if (!config.quiet) {
    training.progress = [&](int level, size_t nodes) {
      std::fprintf(stderr, "semmap-train-vocab: level %d/%d: %zu nodes (%.1f s)\n", level,
                   training.levels, nodes, SecondsSince(train_start));
    };
  }
  StatusOr<BowVocabulary> vocabulary = BowVocabulary::Train(sets, training);
  if (!vocabulary.ok()) {
    std::cerr << "semmap-train-vocab: " << vocabulary.status().ToString() << "\n";
    return kExitError;
  }
  const double train_s = SecondsSince(train_start);

  std::error_code ec;
  const std::filesystem::path parent = std::filesystem::path(config.out_path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  if (Status s = vocabulary->Save(config.out_path); !s.ok()) {
    std::cerr << "semmap-train-vocab: " << s.ToString() << "\n";
    return kExitError;
  }
  const std::string bytes = vocabulary->Serialize();
  std::printf(
      "trained %zu words (%zu nodes, k %d, L %d) from %zu descriptors of %zu images in %.1f s "
      "(extract %.1f s, train %.1f s)\nwrote %s: %zu bytes, sha256 %s\n",
      vocabulary->NumWords(), vocabulary->NumNodes(), vocabulary->branching(), vocabulary->levels(),
      descriptors, sets.size(), SecondsSince(start), extract_s, train_s, config.out_path.c_str(),
      bytes.size(), ToHex(Sha256(bytes)).c_str());
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  ArgParser parser = MakeParser();
  // ArgParser spells one-letter flags "-k"; accept the documented "--k" too.
  std::vector<std::string> args(argv, argv + argc);
  for (size_t i = 1; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") {
      std::cout << Usage(parser);
      return kExitOk;
    }
    if (args[i] == "--k" || args[i] == "--o") args[i] = args[i].substr(1);
    if (args[i].rfind("--k=", 0) == 0 || args[i].rfind("--o=", 0) == 0) {
      args.insert(args.begin() + static_cast<long>(i) + 1, args[i].substr(4));
      args[i] = args[i].substr(1, 2);
    }
  }
  std::vector<const char*> cargs;
  cargs.reserve(args.size());
  for (const std::string& a : args) cargs.push_back(a.c_str());
  Config config;
  Status parsed = parser.Parse(static_cast<int>(cargs.size()), cargs.data());
  if (parsed.ok()) parsed = ParseConfig(parser, &config);
  if (!parsed.ok()) {
    std::cerr << "semmap-train-vocab: " << parsed.message() << "\n\n" << Usage(parser);
    return kExitUsage;
  }
  return Run(config);
}
