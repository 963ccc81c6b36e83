#pragma once
/// @file sim_bag_test_support.h
/// @brief What the end-to-end simulator tests share: a per-process scratch directory, short
/// sequences generated through the real rosbag sink, and byte-level comparisons.

#include <ros/serialization.h>
#include <ros/time.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "bag_sink.h"
#include "vims_common/sequence_paths.h"
#include "vims_sim/sequence_generator.h"
#include "vims_sim/sim_setup.h"

namespace vims {
namespace sim {
namespace bag_test {

namespace fs = std::filesystem;

inline const fs::path& tempRoot() {
  static const fs::path root = [] {
    const fs::path p = fs::temp_directory_path() / ("vims_sim_bag_test_" + std::to_string(::getpid()));
    fs::create_directories(p);
    return p;
  }();
  return root;
}

inline SimOptions baseOptions(const std::string& name, double duration, uint64_t seed) {
  SimOptions o;
  o.scenario = Scenario::kTank;
  o.duration = duration;
  o.seed = seed;
  o.out_dir = (tempRoot() / name).string();
  return o;
}

inline GenerationStats generate(const SimOptions& options) {
  ros::Time::init();
  const SimSetup setup = buildSimSetup(options);
  const auto paths = vims::SequencePaths::forWriting(options.out_dir, options.sequenceName());
  fs::create_directories(options.out_dir);
  BagSink sink(paths.bag, options.lz4, setup.config, setup.sonar, setup.imu);
  const GenerationStats stats = generateSequence(setup, sink);
  sink.close();
  return stats;
}

inline std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Every message of a bag, serialised, per topic (for bit-exact comparisons).
inline std::map<std::string, std::vector<std::vector<uint8_t>>> serialisedMessages(const std::string& bag_path) {
  rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
  rosbag::View view(bag);
  std::map<std::string, std::vector<std::vector<uint8_t>>> out;
  for (const rosbag::MessageInstance& m : view) {
    std::vector<uint8_t> buffer(m.size());
    ros::serialization::OStream stream(buffer.data(), static_cast<uint32_t>(buffer.size()));
    m.write(stream);
    out[m.getTopic()].push_back(std::move(buffer));
  }
  return out;
}

inline double toSeconds(const ros::Time& t) { return t.toSec(); }

/// 64-bit FNV-1a of a file's bytes.
inline uint64_t fileHash(const std::string& path) {
  uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : readFile(path)) h = (h ^ c) * 0x100000001b3ULL;
  return h;
}

}  // namespace bag_test
}  // namespace sim
}  // namespace vims
