/// vims_vocab_train: trains a BinaryVocabulary from images or from a VIMS sequence bag.
/// See docs/vocabulary.md for the algorithm, the file format and the reproducing commands.

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "vims_common/log.h"
#include "vims_common/sequence_config.h"
#include "vims_common/sequence_paths.h"
#include "vims_pose_graph/feature_extraction.h"
#include "vims_pose_graph/image_list.h"
#include "vims_pose_graph/vocabulary.h"
#include "vims_ros/sequence_bag_reader.h"

namespace {

const char* kUsage =
    "usage: vims_vocab_train (--images DIR_OR_LIST | --sequence DIR) --out FILE\n"
    "                        [--every N] [--k 8] [--levels 4] [--seed 1] [--iterations 20]\n"
    "                        [--descriptor orb|brief] [--max-features 500] [--fast-threshold 10]\n"
    "  --images DIR_OR_LIST  a directory of images, or a text file with one image path per line\n"
    "  --sequence DIR        a VIMS sequence directory (<seq>.bag + <seq>.yaml); uses its camera topic\n"
    "  --every N             use every N-th image (default 1)\n"
    "  --out FILE            vocabulary file to write\n"
    "  --k, --levels         branching factor and depth of the tree\n"
    "  --seed                seed of the k-means++ seeding (same input + seed = same file)\n"
    "  --iterations          maximum k-medians iterations per node\n"
    "  --descriptor          orb (oriented, multi-scale) or brief (unoriented, single scale)\n"
    "  --max-features        features per image\n"
    "  --fast-threshold      FAST corner threshold (use the loop closer's setting)\n";

struct Args {
  std::string images, sequence, out;
  int every = 1;
  vims::VocabularyTrainingOptions training;
  vims::FeatureExtractionOptions features;
};

int parseInt(const std::string& flag, const std::string& value) {
  try {
    size_t used = 0;
    const long v = std::stol(value, &used);
    if (used != value.size()) throw std::invalid_argument("trailing characters");
    return static_cast<int>(v);
  } catch (const std::exception&) {
    throw std::invalid_argument(flag + ": expected an integer, got '" + value + "'");
  }
}

Args parseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "-h" || flag == "--help") {
      std::cout << kUsage;
      std::exit(0);
    }
    if (i + 1 >= argc) throw std::invalid_argument(flag + ": missing value (or unknown flag)");
    const std::string v = argv[++i];
    if (flag == "--images")
      a.images = v;
    else if (flag == "--sequence")
      a.sequence = v;
    else if (flag == "--out")
      a.out = v;
    else if (flag == "--every")
      a.every = parseInt(flag, v);
    else if (flag == "--k")
      a.training.branching = parseInt(flag, v);
    else if (flag == "--levels")
      a.training.levels = parseInt(flag, v);
    else if (flag == "--seed")
      a.training.seed = static_cast<uint64_t>(parseInt(flag, v));
    else if (flag == "--iterations")
      a.training.max_iterations = parseInt(flag, v);
    else if (flag == "--max-features")
      a.features.max_features = parseInt(flag, v);
    else if (flag == "--fast-threshold")
      a.features.fast_threshold = parseInt(flag, v);
    else if (flag == "--descriptor") {
      a.features.descriptor = vims::descriptorTypeFromString(v);
      a.training.descriptor_type = v;
    } else {
      throw std::invalid_argument("unknown flag '" + flag + "'");
    }
  }
  if (a.images.empty() == a.sequence.empty())
    throw std::invalid_argument("give exactly one of --images and --sequence");
  if (a.out.empty()) throw std::invalid_argument("--out is required");
  if (a.every < 1) throw std::invalid_argument("--every must be >= 1");
  if (a.features.max_features < 1) throw std::invalid_argument("--max-features must be >= 1");
  if (a.features.fast_threshold < 1 || a.features.fast_threshold > 254)
    throw std::invalid_argument("--fast-threshold must be in [1, 254]");
  a.training.validate();
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  try {
    args = parseArgs(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "vims_vocab_train: " << e.what() << "\n" << kUsage;
    return 2;
  }
  const vims::LoggerPtr logger = vims::Logger::stderrLogger();
  try {
    const auto start = std::chrono::steady_clock::now();
    vims::FeatureExtractor extractor(args.features);
    std::vector<std::vector<vims::BinaryDescriptor>> images;
    size_t seen = 0;
    auto addImage = [&](const cv::Mat& mono) {
      if (seen++ % static_cast<size_t>(args.every) != 0) return;
      images.push_back(extractor.extract(mono).descriptors);
    };
    if (!args.images.empty()) {
      for (const std::string& path : vims::listTrainingImages(args.images)) {
        const cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
        if (img.empty()) {
          logger->warn("vocab_train", "cannot read image '" + path + "', skipped");
          continue;
        }
        addImage(img);
      }
    } else {
      const vims::SequencePaths paths = vims::SequencePaths::resolve(args.sequence);
      const vims::SequenceConfig config = vims::SequenceConfig::load(paths.yaml);
      vims::SequenceBagReader reader(paths.bag, config);
      vims::SequenceBagReader::Handlers handlers;
      handlers.image = [&](const vims::CameraFrame& frame) { addImage(frame.image); };
      reader.run(handlers);
    }
    size_t descriptors = 0;
    for (const auto& d : images) descriptors += d.size();
    logger->info("vocab_train",
                 VIMS_STR("extracted " << descriptors << " " << args.training.descriptor_type << " descriptors from "
                                       << images.size() << " of " << seen << " images"));
    const vims::BinaryVocabulary voc = vims::BinaryVocabulary::train(images, args.training, logger);
    voc.save(args.out);
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    logger->info("vocab_train", VIMS_STR("wrote " << args.out << " (" << std::filesystem::file_size(args.out)
                                                  << " bytes, " << voc.numWords() << " words) in " << elapsed << " s"));
  } catch (const std::exception& e) {
    logger->error("vocab_train", e.what());
    return 1;
  }
  return 0;
}
