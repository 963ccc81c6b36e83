#include "vims_pose_graph/image_list.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <set>
#include <stdexcept>

namespace vims {

namespace fs = std::filesystem;

std::vector<std::string> listTrainingImages(const std::string& dir_or_list) {
  std::error_code ec;
  if (!fs::exists(dir_or_list, ec)) throw std::runtime_error("'" + dir_or_list + "' does not exist");
  std::vector<std::string> out;
  if (fs::is_directory(dir_or_list, ec)) {
    const std::set<std::string> kExtensions = {".png", ".jpg", ".jpeg", ".pgm", ".ppm", ".bmp", ".tif", ".tiff"};
    for (const fs::directory_entry& e : fs::directory_iterator(dir_or_list)) {
      if (!e.is_regular_file()) continue;
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      if (kExtensions.count(ext)) out.push_back(e.path().string());
    }
    std::sort(out.begin(), out.end());
  } else {
    std::ifstream in(dir_or_list);
    if (!in) throw std::runtime_error("cannot read image list '" + dir_or_list + "'");
    const fs::path base = fs::path(dir_or_list).parent_path();
    std::string line;
    while (std::getline(in, line)) {
      const size_t b = line.find_first_not_of(" \t\r");
      if (b == std::string::npos || line[b] == '#') continue;
      const size_t e = line.find_last_not_of(" \t\r");
      fs::path p(line.substr(b, e - b + 1));
      if (p.is_relative()) p = base / p;
      out.push_back(p.string());
    }
  }
  if (out.empty()) throw std::runtime_error("no images found in '" + dir_or_list + "'");
  return out;
}

}  // namespace vims
