#include "vims_common/sequence_paths.h"

#include <filesystem>
#include <stdexcept>
#include <vector>

namespace fs = std::filesystem;

namespace vims {

SequencePaths SequencePaths::forWriting(const std::string& dir, const std::string& name) {
  SequencePaths p;
  p.dir = dir;
  p.name = name;
  const fs::path d(dir);
  p.bag = (d / (name + ".bag")).string();
  p.yaml = (d / (name + ".yaml")).string();
  p.gt = (d / (name + "_gt.tum")).string();
  p.truth = (d / (name + "_truth.yaml")).string();
  return p;
}

SequencePaths SequencePaths::resolve(const std::string& dir) {
  const fs::path d(dir);
  if (!fs::is_directory(d)) throw std::runtime_error("sequence directory '" + dir + "' does not exist");
  std::string name = fs::absolute(d).lexically_normal().filename().string();
  if (name.empty()) name = fs::absolute(d).lexically_normal().parent_path().filename().string();
  if (!fs::exists(d / (name + ".bag"))) {
    std::vector<std::string> bags;
    for (const auto& entry : fs::directory_iterator(d))
      if (entry.path().extension() == ".bag") bags.push_back(entry.path().stem().string());
    if (bags.size() == 1) {
      name = bags.front();
    } else if (bags.empty()) {
      throw std::runtime_error("sequence directory '" + dir + "' has no bag (expected '" + name + ".bag')");
    } else {
      throw std::runtime_error("sequence directory '" + dir + "' has several bags and none is named '" + name +
                               ".bag'");
    }
  }
  SequencePaths p = forWriting(dir, name);
  if (!fs::exists(p.yaml))
    throw std::runtime_error("sequence '" + dir + "' is missing its configuration '" + p.yaml + "'");
  if (!fs::exists(p.gt)) p.gt.clear();
  if (!fs::exists(p.truth)) p.truth.clear();
  return p;
}

}  // namespace vims
